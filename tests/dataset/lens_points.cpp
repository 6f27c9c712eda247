// A test-only tool for tests/dataset/opencv_lens_check.py: Mucosa's
// dataset::project of points read from stdin, so Python can compare them
// with OpenCV's. Not part of the command-line tool.
//
// Usage: lens_points LENS.json < points
// Each input line "X Y Z" (camera frame, OpenCV axes) prints one line: the
// pixel "u v" (17 significant digits), or "none" where project() has none.
#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>

#include <mucosa/core/error.hpp>
#include <mucosa/dataset/lens.hpp>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: lens_points LENS.json < points\n");
        return 2;
    }
    try {
        const mucosa::dataset::Lens lens = mucosa::dataset::readLens(argv[1]);
        std::string line;
        int number = 0;
        while (std::getline(std::cin, line)) {
            ++number;
            std::istringstream in(line);
            mucosa::dataset::Vec3d p{};
            if (!(in >> p[0] >> p[1] >> p[2])) {
                std::fprintf(stderr, "error: line %d of the points: not three numbers\n", number);
                return 1;
            }
            if (const auto px = mucosa::dataset::project(lens, p))
                std::printf("%.17g %.17g\n", px->u, px->v);
            else
                std::printf("none\n");
        }
    } catch (const mucosa::Error& e) {
        std::fprintf(stderr, "error: %s\n", mucosa::describe(e).c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
