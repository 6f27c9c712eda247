#pragma once
// What every failing command must look like from the outside.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace mucosa::test {

inline int lineCount(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

// One `error: ...` line on stderr mentioning `mentions`, and a non-zero exit.
inline void expectOneErrorLine(const RunResult& r, const std::string& mentions, const std::string& args = "") {
    EXPECT_NE(r.exitCode, 0) << args;
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << args << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << args << "\n" << r.err;
}

}  // namespace mucosa::test
