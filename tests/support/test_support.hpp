#pragma once
// Helpers shared by Mucosa's tests.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace mucosa::test {

inline std::filesystem::path testdata(const std::string& rel) {
    const std::filesystem::path p = std::filesystem::path(MUCOSA_TESTDATA_DIR) / rel;
    if (!std::filesystem::exists(p))
        throw std::runtime_error("test data missing: " + p.string() + " (tests/data is part of the repository)");
    return p;
}

// A fresh directory under the build tree, removed at the end of the test.
class TempDir {
public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "mucosa";
        path_ = std::filesystem::temp_directory_path() / ("mucosa-test-" + name + "-" + std::to_string(::getpid()));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    const std::filesystem::path& path() const { return path_; }
    std::filesystem::path operator/(const std::string& s) const { return path_ / s; }

private:
    std::filesystem::path path_;
};

struct RunResult {
    int exitCode = -1;
    std::string out, err;
};

// Runs the mucosa CLI with `args` (a shell-quoted string), capturing output.
inline RunResult runCli(const std::string& args, const std::filesystem::path& cwd = {}) {
    const auto tmp = std::filesystem::temp_directory_path();
    const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(std::rand());
    const auto outFile = tmp / ("mucosa-cli-out-" + tag), errFile = tmp / ("mucosa-cli-err-" + tag);
    std::string cmd;
    if (!cwd.empty()) cmd += "cd '" + cwd.string() + "' && ";
    cmd += std::string("'") + MUCOSA_CLI + "' " + args + " >'" + outFile.string() + "' 2>'" + errFile.string() +
           "' </dev/null";
    const int status = std::system(cmd.c_str());
    RunResult r;
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    auto slurp = [](const std::filesystem::path& p) {
        std::ifstream in(p);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    r.out = slurp(outFile);
    r.err = slurp(errFile);
    std::filesystem::remove(outFile);
    std::filesystem::remove(errFile);
    return r;
}

inline std::string readBytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

}  // namespace mucosa::test
