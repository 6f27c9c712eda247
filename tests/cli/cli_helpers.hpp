#pragma once
// What every failing command must look like from the outside.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include <mucosa/image/png.hpp>

#include "test_support.hpp"

namespace mucosa::test {

// The share of pixels where a dataset's mask (mask.png) says what the colour
// frame shows: lit (any channel above 0) inside the mask, black outside.
inline double maskAgreesWithLitPixels(const image::PngImage& rgb, const image::PngImage& mask) {
    int agree = 0;
    const int w = rgb.pixels.width(), h = rgb.pixels.height();
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool lit = rgb.pixels.at(x, y, 0) + rgb.pixels.at(x, y, 1) + rgb.pixels.at(x, y, 2) > 0;
            agree += lit == (mask.pixels.at(x, y) > 0);
        }
    return static_cast<double>(agree) / (static_cast<double>(w) * h);
}

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
