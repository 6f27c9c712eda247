// A test-only tool for the OpenCV cross-checks of the lens models: Mucosa's
// dataset::project of points read from stdin (tests/dataset/opencv_lens_check.py),
// and the ground truth through a lens (tests/dataset/opencv_lens_truth_check.py),
// so Python can compare them with OpenCV's. Not part of the command-line tool.
//
// Usage: lens_points LENS.json < points
// Each input line "X Y Z" (camera frame, OpenCV axes) prints one line: the
// pixel "u v" (17 significant digits), or "none" where project() has none.
//
// Usage: lens_points --truth LENS.json MESH < camera_to_world
// Reads the mesh (millimetres, any format mesh::load reads) and a row-major
// camera_to_world (16 numbers) from stdin, computes dataset::groundTruth
// through the lens, and prints one line per pixel that sees a surface:
// "x y face b1 b2 depth" (the barycentrics and the planar depth as stored,
// 9 significant digits).
#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>

#include <mucosa/core/error.hpp>
#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/mesh/io.hpp>

namespace {

int projectPoints(const mucosa::dataset::Lens& lens) {
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
    return 0;
}

int truth(const mucosa::dataset::Lens& lens, const char* meshPath) {
    mucosa::mesh::LoadOptions options;
    options.unit = mucosa::mesh::Unit::Millimetres;
    const mucosa::mesh::Mesh mesh = mucosa::mesh::load(meshPath, options);
    mucosa::frames::Mat4 c2w{};
    for (auto& row : c2w)
        for (double& v : row)
            if (!(std::cin >> v)) {
                std::fprintf(stderr, "error: camera_to_world: expected 16 numbers on stdin\n");
                return 1;
            }
    const mucosa::dataset::GroundTruth t = mucosa::dataset::groundTruth(mesh, lens, c2w, 0.5);
    std::printf("# %zu triangles\n", mesh.triangleCount());
    for (int y = 0; y < t.height; ++y)
        for (int x = 0; x < t.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * t.width + x;
            if (t.valid[i])
                std::printf("%d %d %d %.9g %.9g %.9g\n", x, y, t.face[i], t.b1[i], t.b2[i], t.depth.at(x, y));
        }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const bool truthMode = argc == 4 && std::string(argv[1]) == "--truth";
    if (argc != 2 && !truthMode) {
        std::fprintf(stderr,
                     "usage: lens_points LENS.json < points\n       lens_points --truth LENS.json MESH < "
                     "camera_to_world\n");
        return 2;
    }
    try {
        const mucosa::dataset::Lens lens = mucosa::dataset::readLens(argv[truthMode ? 2 : 1]);
        return truthMode ? truth(lens, argv[3]) : projectPoints(lens);
    } catch (const mucosa::Error& e) {
        std::fprintf(stderr, "error: %s\n", mucosa::describe(e).c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
