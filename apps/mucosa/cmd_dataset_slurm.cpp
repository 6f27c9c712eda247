// mucosa dataset slurm: a plan's shards as one Slurm job array. Writes
// DIR/slurm/run.sbatch, whose task I runs `mucosa dataset run DIR --shard I/K`
// with this very binary, and with --submit hands it to sbatch (docs/slurm.md).
// Slurm restarts a task that fails or is requeued from its beginning; `run`
// skips the frames already done, so a restart only renders what is missing.
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "commands.hpp"
#include "dataset_plan.hpp"

extern char** environ;

namespace mucosa::cli {

namespace {

namespace fs = std::filesystem;

struct SlurmArgs {
    std::string dir;
    int shards = 0;
    std::string partition, time, gres, mem;
    int cpusPerTask = 0;  // 0: not asked for
    bool submit = false;
};

// A word for a POSIX shell: single-quoted, so nothing in it expands.
std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

// A path in an #SBATCH line, then a Slurm file name pattern: sbatch reads a
// double-quoted argument with \" for a quote, and the pattern reads %% as a %.
std::string sbatchPath(const std::string& path, const std::string& pattern) {
    std::string q = "\"";
    for (char c : path) {
        if (c == '"')
            q += "\\\"";
        else if (c == '%')
            q += "%%";
        else
            q += c;
    }
    return q + pattern + "\"";
}

// A path the script names: sbatch and Slurm's file name patterns cannot carry
// a backslash ("do not expand %A") or a control character.
void requireScriptable(const fs::path& p, const std::string& what) {
    for (unsigned char c : p.string())
        if (c == '\\' || c < 0x20 || c == 0x7f)
            throw InputError(what, p.string(),
                             "contains a backslash or a control character, which a Slurm batch script cannot name; "
                             "use another path");
}

// An option passed on to sbatch as is: one word, nothing a shell or sbatch's
// #SBATCH parser would read differently.
void requireSbatchValue(const std::string& option, const std::string& value) {
    if (value.empty()) throw InputError(option, "", "must not be empty");
    for (unsigned char c : value)
        if (c <= 0x20 || c == 0x7f || c == '"' || c == '\'' || c == '\\' || c == '#')
            throw InputError(
                option, "",
                fmt::format("'{}' is not one word without quotes, backslashes or '#' (as sbatch takes it)", value));
}

// "mucosa-" and the folder's name, in the characters every Slurm tool shows.
std::string jobName(const fs::path& dir) {
    std::string name = "mucosa-";
    for (char c : dir.filename().string())
        name += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
    return name.size() > 64 ? name.substr(0, 64) : name;
}

// The plan's segments (the unit of sharding), read to warn when shards would
// be left empty; the plan itself is checked in full by every task's `run`.
int planSegments(const fs::path& file) {
    if (!fs::exists(file))
        throw InputError("plan", file.string(), "no such file (mucosa dataset plan ... -o DIR writes it)");
    const nlohmann::json j = nlohmann::json::parse(readTextFile(file), nullptr, false);
    const auto whole = [&](const char* key) {
        return j.is_object() && j.contains(key) && j[key].is_number_integer() && j[key].get<long long>() >= 1;
    };
    if (!whole("frames") || !whole("segment_frames"))
        throw InputError("plan", file.string(), "is not a Mucosa plan (mucosa dataset plan ... -o DIR writes it)");
    const long long frames = j["frames"].get<long long>(), segment = j["segment_frames"].get<long long>();
    return static_cast<int>(std::min<long long>((frames + segment - 1) / segment, 1 << 30));
}

// This binary, as every task will run it.
fs::path selfPath() {
    std::error_code ec;
    fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw IoError("mucosa binary", "/proc/self/exe", "cannot be read: " + ec.message());
    const std::string deleted = " (deleted)";
    const std::string s = self.string();
    if (s.size() > deleted.size() && s.compare(s.size() - deleted.size(), deleted.size(), deleted) == 0)
        throw IoError("mucosa binary", s.substr(0, s.size() - deleted.size()),
                      "was replaced while this one ran; run the new one");
    return self;
}

std::string sbatchScript(const SlurmArgs& a, const fs::path& dir, const fs::path& self) {
    const fs::path logs = dir / "slurm";
    std::string s;
    s += "#!/bin/bash\n";
    s += fmt::format("# Renders the Mucosa dataset plan {} as {} of a Slurm job array.\n", dir.string(),
                     count(static_cast<std::uint64_t>(a.shards), "shard"));
    s += "# Written by `mucosa dataset slurm` (docs/slurm.md). Task I renders shard I/K; a task\n"
         "# that is killed, fails or is requeued renders only the frames it has not finished\n"
         "# (each frame is written atomically, its .sha256 last). When every task has ended:\n";
    s += fmt::format("#   {} dataset verify {}\n", shellQuote(self.string()), shellQuote(dir.string()));
    s += fmt::format("#SBATCH --job-name={}\n", jobName(dir));
    s += fmt::format("#SBATCH --array=0-{}\n", a.shards - 1);
    s += fmt::format("#SBATCH --output={}\n", sbatchPath(logs.string(), "/%A_%a.out"));
    s += "#SBATCH --open-mode=append\n";  // a requeued task's log keeps the earlier attempts
    s += "#SBATCH --requeue\n";
    if (!a.partition.empty()) s += fmt::format("#SBATCH --partition={}\n", a.partition);
    if (!a.time.empty()) s += fmt::format("#SBATCH --time={}\n", a.time);
    if (!a.gres.empty()) s += fmt::format("#SBATCH --gres={}\n", a.gres);
    if (a.cpusPerTask > 0) s += fmt::format("#SBATCH --cpus-per-task={}\n", a.cpusPerTask);
    if (!a.mem.empty()) s += fmt::format("#SBATCH --mem={}\n", a.mem);
    s += "echo \"mucosa dataset slurm: task ${SLURM_ARRAY_TASK_ID} of job ${SLURM_ARRAY_JOB_ID} on $(hostname),"
         " attempt $((${SLURM_RESTART_COUNT:-0} + 1)), $(date -u +%FT%TZ)\" >&2\n";
    // Worker threads: the CPUs Slurm gave the task, when it was asked for some.
    const std::string threads = a.cpusPerTask > 0 ? fmt::format(" --threads {}", a.cpusPerTask) : "";
    s += fmt::format(
        "exec {}{} dataset run {} --shard \"${{SLURM_ARRAY_TASK_ID:?submit this script with sbatch}}/{}\"\n",
        shellQuote(self.string()), threads, shellQuote(dir.string()), a.shards);
    return s;
}

struct Finished {
    int status = 0;  // waitpid status
    std::string out, err;
};

// Runs a program found on PATH with these arguments (no shell), stdin from
// /dev/null, and collects its stdout and stderr. Throws IoError with `missing`
// as the reason when there is no such program.
Finished runProgram(const std::vector<std::string>& args, const std::string& missing) {
    int outPipe[2], errPipe[2];
    if (::pipe2(outPipe, O_CLOEXEC) != 0) throw IoError(args[0], "", std::strerror(errno));
    if (::pipe2(errPipe, O_CLOEXEC) != 0) {
        ::close(outPipe[0]);
        ::close(outPipe[1]);
        throw IoError(args[0], "", std::strerror(errno));
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, outPipe[1], 1);
    posix_spawn_file_actions_adddup2(&actions, errPipe[1], 2);
    std::vector<char*> argv;
    for (const std::string& s : args) argv.push_back(const_cast<char*>(s.c_str()));
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int spawned = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(outPipe[1]);
    ::close(errPipe[1]);
    if (spawned != 0) {
        ::close(outPipe[0]);
        ::close(errPipe[0]);
        if (spawned == ENOENT) throw IoError(args[0], "", missing);
        throw IoError(args[0], "", fmt::format("cannot be started: {}", std::strerror(spawned)));
    }
    Finished f;
    pollfd fds[2] = {{outPipe[0], POLLIN, 0}, {errPipe[0], POLLIN, 0}};
    std::string* into[2] = {&f.out, &f.err};
    int open = 2;
    while (open > 0) {
        if (::poll(fds, 2, -1) < 0) {
            if (errno == EINTR) continue;
            break;
        }
        for (int k = 0; k < 2; ++k) {
            if (fds[k].fd < 0 || fds[k].revents == 0) continue;
            char buf[4096];
            const ssize_t n = ::read(fds[k].fd, buf, sizeof buf);
            if (n > 0) {
                into[k]->append(buf, static_cast<std::size_t>(n));
            } else if (n == 0 || errno != EINTR) {
                ::close(fds[k].fd);
                fds[k].fd = -1;
                --open;
            }
        }
    }
    for (pollfd& p : fds)
        if (p.fd >= 0) ::close(p.fd);
    while (::waitpid(pid, &f.status, 0) < 0 && errno == EINTR) {
    }
    return f;
}

// A program's message on one line: lines joined with "; ", spaces trimmed.
std::string oneLine(const std::string& text) {
    std::string line, out;
    for (std::size_t i = 0; i <= text.size(); ++i) {
        if (i < text.size() && text[i] != '\n' && text[i] != '\r') {
            line += text[i];
            continue;
        }
        const auto b = line.find_first_not_of(" \t"), e = line.find_last_not_of(" \t");
        if (b != std::string::npos) out += (out.empty() ? "" : "; ") + line.substr(b, e - b + 1);
        line.clear();
    }
    return out;
}

void runSlurm(const SlurmArgs& a, const Global& g) {
    fs::path dir = fs::absolute(a.dir).lexically_normal();
    if (!dir.has_filename()) dir = dir.parent_path();  // "data/" -> "data"
    const fs::path plan = dir / "plan.json";
    const int segments = planSegments(plan);
    requireScriptable(dir, "dataset folder");
    const std::pair<const char*, const std::string*> passed[] = {
        {"--partition", &a.partition}, {"--time", &a.time}, {"--gres", &a.gres}, {"--mem", &a.mem}};
    for (const auto& [option, value] : passed)
        if (!value->empty()) requireSbatchValue(option, *value);
    const fs::path self = selfPath();
    requireScriptable(self, "mucosa binary");
    if (a.shards > segments)
        warn(fmt::format("{} has {}, the unit of sharding: {} of {} shards will find nothing to render", plan.string(),
                         count(static_cast<std::uint64_t>(segments), "segment"),
                         a.shards - 1 == segments ? fmt::format("task {}", segments)
                                                  : fmt::format("tasks {}..{}", segments, a.shards - 1),
                         a.shards));

    const fs::path logs = dir / "slurm";
    const fs::path script = logs / "run.sbatch";
    requireOutputDir(logs);
    fs::create_directories(logs);
    writeFileAtomic(script, sbatchScript(a, dir, self));
    const std::string submit = "sbatch " + shellQuote(script.string());
    if (!a.submit) {
        info(g, fmt::format("wrote {}: a job array of {}, logs in {}", script.string(),
                            count(static_cast<std::uint64_t>(a.shards), "task"), joinPath(logs, "")));
        info(g, fmt::format("submit it with: {}", submit));
        return;
    }
    const Finished f = runProgram(
        {"sbatch", "--parsable", script.string()},
        "not found on PATH: run this on a Slurm login node, or submit " + script.string() + " there with sbatch");
    if (!WIFEXITED(f.status) || WEXITSTATUS(f.status) != 0) {
        const std::string how = WIFEXITED(f.status) ? fmt::format("exit status {}", WEXITSTATUS(f.status))
                                                    : fmt::format("signal {}", WTERMSIG(f.status));
        const std::string said = oneLine(f.err + "\n" + f.out);
        throw IoError("sbatch", script.string(), fmt::format("failed ({}){}", how, said.empty() ? "" : ": " + said));
    }
    // --parsable prints "jobid" or "jobid;cluster".
    const std::string reply = oneLine(f.out);
    const std::string id = reply.substr(0, reply.find(';'));
    if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
        throw IoError("sbatch", script.string(), fmt::format("gave no job id (it printed '{}')", reply));
    if (g.quiet) {
        std::fprintf(stdout, "%s\n", id.c_str());
        return;
    }
    info(g, fmt::format("submitted job {}: {} ({}_0 .. {}_{}), logs in {}", id,
                        count(static_cast<std::uint64_t>(a.shards), "array task"), id, id, a.shards - 1,
                        joinPath(logs, "")));
    info(g, fmt::format("watch it with: squeue -j {}; when it has ended: mucosa dataset verify {}", id,
                        shellQuote(dir.string())));
}

}  // namespace

void addSlurmCommand(CLI::App& dataset, Global& g) {
    auto a = std::make_shared<SlurmArgs>();
    CLI::App* c = dataset.add_subcommand(
        "slurm",
        "Render a plan on a Slurm cluster: one job array, task I rendering shard I of K (DIR/slurm/run.sbatch); "
        "tasks killed or requeued resume");
    c->footer(
        "Examples: mucosa dataset slurm data --shards 32 --partition gpu --gres gpu:1 --time 2:00:00 --submit\n"
        "          mucosa dataset slurm data --shards 4   (writes data/slurm/run.sbatch; submit it with sbatch)\n"
        "Then: squeue -j JOB; mucosa dataset verify data (lists what a rerun must render).\n"
        "With -q, --submit prints only the job id. docs/slurm.md.");
    c->add_option("dir", a->dir,
                  "The dataset's folder (mucosa dataset plan -o DIR); every node must see it at "
                  "this path")
        ->required();
    c->add_option("--shards", a->shards, "K: tasks in the array, each rendering one shard")
        ->required()
        ->check(wholeNumber(1));
    c->add_option("--partition", a->partition, "sbatch --partition: where the tasks run [the cluster's default]");
    c->add_option("--time", a->time, "sbatch --time: each task's time limit, e.g. 2:00:00 [the partition's]");
    c->add_option("--gres", a->gres, "sbatch --gres: e.g. gpu:1, one GPU per task for EGL rendering");
    c->add_option("--cpus-per-task", a->cpusPerTask,
                  "sbatch --cpus-per-task: CPUs per task, and each task's worker threads [Slurm's default; all cores]")
        ->check(wholeNumber(1));
    c->add_option("--mem", a->mem, "sbatch --mem: memory per task, e.g. 16G [the partition's default]");
    c->add_flag("--submit", a->submit, "Submit the array with sbatch and print its job id (else print the command)");
    c->callback([a, &g] { runSlurm(*a, g); });
}

}  // namespace mucosa::cli
