#include "isolate.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <new>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

// Sanitizer runtimes (and libFuzzer through them) run a callback when they
// report an error; in the child that callback belongs to the parent's world
// (libFuzzer would save the input as a crash of the parent), so the child
// clears it. Weak: absent in plain builds.
extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

#if defined(__SANITIZE_ADDRESS__)
#define MUCOSA_ISOLATE_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MUCOSA_ISOLATE_ASAN 1
#endif
#endif

namespace mucosa::detail {

namespace {

enum Status : char { kOk = 0, kMucosaError = 1, kOutOfMemory = 2, kOtherException = 3 };
enum Kind : char { kInput = 1, kIo = 2, kResource = 3 };

void putString(std::string& out, const std::string& s) {
    const auto n = static_cast<std::uint32_t>(s.size());
    out.append(reinterpret_cast<const char*>(&n), 4);
    out += s;
}

bool getString(const std::string& in, std::size_t& at, std::string& s) {
    std::uint32_t n = 0;
    if (in.size() - at < 4) return false;
    std::memcpy(&n, in.data() + at, 4);
    at += 4;
    if (in.size() - at < n) return false;
    s.assign(in, at, n);
    at += n;
    return true;
}

bool writeAll(int fd, const char* p, std::size_t n) {
    while (n > 0) {
        const ssize_t w = ::write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        p += w;
        n -= static_cast<std::size_t>(w);
    }
    return true;
}

std::uint64_t statmPages(pid_t pid, int field) {
    const std::string path = pid == 0 ? "/proc/self/statm" : fmt::format("/proc/{}/statm", pid);
    std::FILE* f = std::fopen(path.c_str(), "r");
    if (!f) return 0;
    unsigned long long size = 0, resident = 0;
    const int n = std::fscanf(f, "%llu %llu", &size, &resident);
    std::fclose(f);
    if (n != 2) return 0;
    return field == 0 ? size : resident;
}

[[noreturn]] void runChild(int fd, pid_t parent, const std::function<std::string()>& work,
                           const IsolationLimits& limits) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(120);  // the parent died before prctl
    if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
    // A crash is a plain signal death: no handler the parent installed
    // (libFuzzer's, a crash reporter's) runs in the child.
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) std::signal(sig, SIG_DFL);
    sigset_t none;
    sigemptyset(&none);
    ::pthread_sigmask(SIG_SETMASK, &none, nullptr);

    const rlimit noCore{0, 0};
    ::setrlimit(RLIMIT_CORE, &noCore);
    const auto cpu = static_cast<rlim_t>(std::ceil(std::max(limits.cpuSeconds, 1.0)));
    const rlimit cpuLimit{cpu, cpu + 1};
    ::setrlimit(RLIMIT_CPU, &cpuLimit);
#ifndef MUCOSA_ISOLATE_ASAN
    const std::uint64_t page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
    const rlimit as{static_cast<rlim_t>(statmPages(0, 0) * page + limits.memoryBytes),
                    static_cast<rlim_t>(statmPages(0, 0) * page + limits.memoryBytes)};
    ::setrlimit(RLIMIT_AS, &as);
#endif

    std::string message;
    try {
        std::string result = work();
        message.reserve(result.size() + 1);
        message += static_cast<char>(kOk);
        message += result;
    } catch (const Error& e) {
        message.clear();
        message += static_cast<char>(kMucosaError);
        message += static_cast<char>(dynamic_cast<const IoError*>(&e)         ? kIo
                                     : dynamic_cast<const ResourceError*>(&e) ? kResource
                                                                              : kInput);
        putString(message, e.subject());
        putString(message, e.file());
        putString(message, e.reason());
    } catch (const std::bad_alloc&) {
        message.assign(1, static_cast<char>(kOutOfMemory));
    } catch (const std::exception& e) {
        message.assign(1, static_cast<char>(kOtherException));
        putString(message, e.what());
    } catch (...) {
        message.assign(1, static_cast<char>(kOtherException));
        putString(message, "an unknown exception");
    }
    ::_exit(writeAll(fd, message.data(), message.size()) ? 0 : 121);
}

}  // namespace

std::string runIsolated(const std::function<std::string()>& work, const IsolationLimits& limits,
                        const std::string& what, const std::string& file) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
        throw ResourceError(what, file, fmt::format("cannot create a pipe: {}", std::strerror(errno)));
    std::fflush(nullptr);  // nothing buffered is written twice
    // The child starts with the caller's resident pages (shared copy-on-write
    // after fork, but counted in its RSS): the limit is on what it adds.
    const std::uint64_t page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
    const std::uint64_t baselineRss = statmPages(0, 1) * page;
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int err = errno;
        ::close(fds[0]);
        ::close(fds[1]);
        throw ResourceError(what, file, fmt::format("cannot start the parser process: {}", std::strerror(err)));
    }
    if (pid == 0) {
        ::close(fds[0]);
        runChild(fds[1], parent, work, limits);
    }
    ::close(fds[1]);
    const int in = fds[0];

    using Clock = std::chrono::steady_clock;
    const auto deadline = Clock::now() + std::chrono::duration<double>(limits.wallSeconds);
    std::string overrun;  // why we killed it
    std::string message;
    bool eof = false;
    char buffer[1 << 16];
    while (!eof) {
        pollfd p{in, POLLIN, 0};
        const int r = ::poll(&p, 1, 20);
        if (r < 0 && errno != EINTR) {
            overrun = fmt::format("waiting for the parser failed: {}", std::strerror(errno));
            break;
        }
        if (r > 0) {
            const ssize_t n = ::read(in, buffer, sizeof buffer);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                eof = true;
                break;
            }
            message.append(buffer, static_cast<std::size_t>(n));
            if (message.size() > limits.maxResultBytes + 1) {
                overrun = fmt::format("the parser's result is larger than {}", formatBytes(limits.maxResultBytes));
                break;
            }
        }
        if (statmPages(pid, 1) * page > baselineRss + limits.memoryBytes) {
            overrun = fmt::format("the parser used more than {} of memory", formatBytes(limits.memoryBytes));
            break;
        }
        if (Clock::now() > deadline) {
            overrun = fmt::format("the parser did not finish within {:g} s", limits.wallSeconds);
            break;
        }
    }
    ::close(in);
    if (!overrun.empty()) ::kill(pid, SIGKILL);
    // After EOF the child is exiting; it still gets the deadline, then SIGKILL.
    int status = 0;
    rusage usage{};
    for (;;) {
        const pid_t w = ::wait4(pid, &status, overrun.empty() ? WNOHANG : 0, &usage);
        if (w == pid) break;
        if (w < 0 && errno != EINTR) throw ResourceError(what, file, "lost the parser process");
        if (w == 0) {
            if (Clock::now() > deadline) {
                overrun = fmt::format("the parser did not finish within {:g} s", limits.wallSeconds);
                ::kill(pid, SIGKILL);
            } else {
                ::usleep(2000);
            }
        }
    }
    if (!overrun.empty()) throw InputError(what, file, overrun);
    if (WIFSIGNALED(status)) {
        const int sig = WTERMSIG(status);
        const double cpuUsed = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                               1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
        if (sig == SIGXCPU || (sig == SIGKILL && cpuUsed >= std::ceil(limits.cpuSeconds)))
            throw InputError(what, file, fmt::format("the parser used more than {:g} s of CPU", limits.cpuSeconds));
        if (sig == SIGKILL)
            throw InputError(what, file,
                             "the parser was killed (signal 9), most likely by the kernel for lack of memory");
        throw InputError(what, file, fmt::format("the parser crashed on it (signal {}: {})", sig, ::strsignal(sig)));
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || message.empty())
        throw InputError(
            what, file,
            fmt::format("the parser failed on it (exit status {})", WIFEXITED(status) ? WEXITSTATUS(status) : -1));

    std::size_t at = 1;
    switch (message[0]) {
        case kOk:
            message.erase(0, 1);
            return message;
        case kMucosaError: {
            std::string subject, errFile, reason;
            const char kind = message.size() > 1 ? message[1] : static_cast<char>(kInput);
            at = 2;
            if (!getString(message, at, subject) || !getString(message, at, errFile) || !getString(message, at, reason))
                break;
            if (kind == kIo) throw IoError(subject, errFile, reason);
            if (kind == kResource) throw ResourceError(subject, errFile, reason);
            throw InputError(subject, errFile, reason);
        }
        case kOutOfMemory:
            throw InputError(what, file,
                             fmt::format("the parser ran out of memory (limit {})", formatBytes(limits.memoryBytes)));
        case kOtherException: {
            std::string text;
            if (!getString(message, at, text)) break;
            throw InputError(what, file, text);
        }
        default:
            break;
    }
    throw InputError(what, file, "the parser's result is malformed");
}

}  // namespace mucosa::detail
