#pragma once
// The Khronos glTF-Validator as a test oracle: expectValidGltf(file) runs
// tests/support/validate_gltf.cjs under Node.js and fails the test on any
// error, any warning or any UNUSED_* info, and when Node.js or
// the validator package (tools/node, scripts/install-deps) is missing.
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

namespace mucosa::test {

inline std::string nodeBinary() {
    if (std::filesystem::exists("/usr/bin/node")) return "/usr/bin/node";
    return std::system("command -v node >/dev/null 2>&1") == 0 ? "node" : "";
}

// The validator's report of `file` (its JSON line), or an empty object after
// a test failure saying why it could not run.
inline nlohmann::json validateGltf(const std::filesystem::path& file) {
    const std::string node = nodeBinary();
    const std::filesystem::path script = std::filesystem::path(MUCOSA_SOURCE_DIR) / "tests/support/validate_gltf.cjs";
    const std::filesystem::path module =
        std::filesystem::path(MUCOSA_SOURCE_DIR) / "tools/node/node_modules/gltf-validator/package.json";
    if (node.empty()) {
        ADD_FAILURE() << "Node.js is not installed: the glTF validation needs it (scripts/install-deps)";
        return nlohmann::json::object();
    }
    if (!std::filesystem::exists(module)) {
        ADD_FAILURE() << "gltf-validator is missing from tools/node/node_modules (run scripts/install-deps)";
        return nlohmann::json::object();
    }
    // Not a TempDir: that would be the calling test's own folder.
    static int calls = 0;
    const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(++calls);
    const std::filesystem::path out = std::filesystem::temp_directory_path() / ("mucosa-gltf-report-" + tag),
                                err = std::filesystem::temp_directory_path() / ("mucosa-gltf-err-" + tag);
    const std::string cmd = "'" + node + "' '" + script.string() + "' '" + file.string() + "' >'" + out.string() +
                            "' 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    const std::string report = readBytes(out), errors = readBytes(err);
    std::filesystem::remove(out);
    std::filesystem::remove(err);
    if (code != 0 && code != 1) {
        ADD_FAILURE() << "the glTF validator did not run on " << file << " (exit " << code << "): " << errors;
        return nlohmann::json::object();
    }
    try {
        return nlohmann::json::parse(report);
    } catch (const std::exception& e) {
        ADD_FAILURE() << "unreadable validator report for " << file << ": " << e.what();
        return nlohmann::json::object();
    }
}

// 0 errors, 0 warnings, no UNUSED_* info.
inline void expectValidGltf(const std::filesystem::path& file) {
    const nlohmann::json r = validateGltf(file);
    if (r.empty()) return;
    std::ostringstream issues;
    for (const auto& m : r["messages"])
        issues << "\n  " << m["code"].get<std::string>() << " (severity " << m["severity"] << ") at "
               << m["pointer"].get<std::string>() << ": " << m["message"].get<std::string>();
    EXPECT_EQ(r["errors"], 0) << file << issues.str();
    EXPECT_EQ(r["warnings"], 0) << file << issues.str();
    EXPECT_EQ(r["unused"], 0) << file << issues.str();
}

}  // namespace mucosa::test
