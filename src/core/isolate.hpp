#pragma once
// Running a parser Mucosa does not own (Assimp) on an untrusted file in a
// child process, so that a crash, a hang or memory exhaustion inside it costs
// the child, never the caller: the caller gets one Error naming the file.
//
// The child is forked (no exec: the library needs no helper binary beside it)
// and runs only `work` before _exit, with:
//   - RLIMIT_AS = its current size + limits.memoryBytes (not under ASan, whose
//     shadow reserves terabytes), RLIMIT_CPU, RLIMIT_CORE = 0 (no core dumps);
//   - PR_SET_PDEATHSIG so it dies with the caller;
// and the parent watches it: a wall-clock deadline, a resident-memory watchdog
// (/proc/<pid>/statm, also under ASan; counted above the caller's own resident
// set at the fork, which the child starts with) and a cap on the result's size. SIGKILL
// ends it on any overrun (Assimp 5.2.5 ignores SIGTERM in its PLY hang).
//
// `work` returns the result as bytes; the caller decodes and validates them
// (the child's memory is not trusted to be well-formed either). A mucosa::Error
// thrown in the child reaches the caller as the same kind and text.
#include <cstdint>
#include <functional>
#include <string>

namespace mucosa::detail {

struct IsolationLimits {
    std::uint64_t memoryBytes = 1ull << 30;  // address space added / resident set
    double cpuSeconds = 60;
    double wallSeconds = 120;
    std::uint64_t maxResultBytes = 1ull << 30;
};

// `what` and `file` name the job in errors ("mesh", "airway.ply").
std::string runIsolated(const std::function<std::string()>& work, const IsolationLimits& limits,
                        const std::string& what, const std::string& file);

}  // namespace mucosa::detail
