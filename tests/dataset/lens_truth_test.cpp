// Ground truth through a lens (dataset::groundTruth with a Lens): exact per
// pixel-centre ray, on analytic scenes, for every lens model.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/fit/frames.hpp>
#include <mucosa/mesh/primitives.hpp>

namespace mucosa {
namespace {

// A camera at (0, 0, 10) looking down -z at the z = 0 plane, up +y: OpenCV
// camera x = world x, y = -world y, z = -world z.
fit::Mat4 lookingDown() {
    return fit::lookAtPose({0, 0, 10}, {0, 0, 0}, {0, 1, 0});
}

dataset::Lens omnidirectional() {
    nlohmann::json j = {{"model", "omnidirectional"}, {"width", 120}, {"height", 90},
                        {"pol", {-50.0, 0.0, 0.004}}, {"xc", 44.5},   {"yc", 59.5}};
    return dataset::lensFromJson(j);
}

std::vector<dataset::Lens> lenses() {
    dataset::Lens kb = dataset::equidistantFisheye(120, 90, 150.0);
    kb.k1 = -0.02, kb.k2 = 0.004, kb.k3 = -0.0005;
    dataset::validateLens(kb);
    dataset::Lens brown = dataset::fromIntrinsics(dataset::intrinsicsOf(camera::Lens{}, 120, 90));
    brown.k1 = -0.1, brown.k2 = 0.01;
    dataset::validateLens(brown);
    return {dataset::equidistantFisheye(120, 90, 160.0), kb, brown, omnidirectional()};
}

TEST(LensTruth, APlaneThroughEveryLensIsExactAtEveryPixel) {
    const mesh::Mesh plane = mesh::makeQuad(400.0f, 8);
    for (const dataset::Lens& lens : lenses()) {
        const dataset::GroundTruth t = dataset::groundTruth(plane, lens, lookingDown(), 0.5);
        int seen = 0;
        double worstDepth = 0, worstPixel = 0, worstNormal = 0;
        for (int y = 0; y < lens.height; ++y)
            for (int x = 0; x < lens.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
                const auto ray = dataset::unproject(lens, x, y);
                EXPECT_EQ(t.inView[i] != 0, ray.has_value());
                // The plane is seen by every ray in front of the camera whose hit is on the 400 mm quad.
                const bool hits = ray && (*ray)[2] > 1e-9 && std::abs((*ray)[0] / (*ray)[2] * 10) < 199 &&
                                  std::abs((*ray)[1] / (*ray)[2] * 10) < 199;
                if (!hits) continue;
                ASSERT_TRUE(t.valid[i]) << dataset::lensModelName(lens.model) << " " << x << "," << y;
                ++seen;
                // Planar depth: the plane is at z = 10 in the camera's frame.
                worstDepth = std::max(worstDepth, std::abs(t.depth.at(x, y) - 10.0) / 10.0);
                // The surface point (ray scaled to the depth) projects back onto the pixel.
                const double s = t.depth.at(x, y) / (*ray)[2];
                const auto p = dataset::project(lens, {(*ray)[0] * s, (*ray)[1] * s, (*ray)[2] * s});
                ASSERT_TRUE(p.has_value());
                worstPixel = std::max(worstPixel, std::hypot(p->u - x, p->v - y));
                // The normal faces the camera: (0, 0, -1) in camera axes.
                worstNormal = std::max(worstNormal, std::acos(std::clamp(-double(t.normals.at(x, y, 2)), -1.0, 1.0)));
                // The texture coordinates say where on the plane: u = x / 400 + 0.5.
                EXPECT_NEAR(t.uv.at(x, y, 0), (*ray)[0] * s / 400.0 + 0.5, 1e-5);
            }
        std::printf("%s: %d pixels, depth %.2g relative, reprojection %.2g px, normal %.2g deg\n",
                    dataset::lensModelName(lens.model), seen, worstDepth, worstPixel, worstNormal * 180 / M_PI);
        EXPECT_GT(seen, lens.width * lens.height / 3);
        EXPECT_LE(worstDepth, 1e-5);
        EXPECT_LE(worstPixel, 1e-3);
        EXPECT_LE(worstNormal * 180 / M_PI, 0.01);
    }
}

TEST(LensTruth, ThePinholeThroughTheCubeIsTheRasterisedPinhole) {
    const mesh::Mesh sphere = mesh::makeSphere(30.0f, 96, 48);  // seen from inside
    const fit::Mat4 c2w = fit::lookAtPose({3, -2, 5}, {10, 4, -20}, {0, 1, 0});
    const fit::Intrinsics K = dataset::intrinsicsOf(camera::Lens{}, 160, 120);
    const dataset::GroundTruth raster = dataset::groundTruth(sphere, K, c2w, 0.5);
    const dataset::GroundTruth cube = dataset::groundTruth(sphere, dataset::fromIntrinsics(K), c2w, 0.5);
    std::size_t same = 0, valid = 0;
    double worst = 0;
    for (std::size_t i = 0; i < raster.face.size(); ++i) {
        EXPECT_EQ(raster.valid[i], cube.valid[i]) << i % 160 << "," << i / 160 << " depth " << raster.depth.data()[i];
        if (!raster.valid[i]) continue;
        ++valid;
        if (raster.face[i] != cube.face[i]) continue;
        ++same;
        worst =
            std::max(worst, std::abs(double(raster.depth.data()[i]) - cube.depth.data()[i]) / raster.depth.data()[i]);
    }
    std::printf("pinhole through the cube: %zu of %zu pixels on the same triangle, depth within %.2g\n", same, valid,
                worst);
    EXPECT_GE(same, 0.995 * static_cast<double>(valid));
    EXPECT_LE(worst, 1e-5);
}

TEST(LensTruth, FlowThroughAFisheyeIsEachPointsReprojection) {
    const mesh::Mesh sphere = mesh::makeSphere(30.0f, 96, 48);
    const dataset::Lens lens = dataset::equidistantFisheye(120, 90, 150.0);
    const fit::Mat4 a = fit::lookAtPose({0, 0, 0}, {0, 0, -20}, {0, 1, 0});
    const fit::Mat4 b = fit::lookAtPose({1, 0.5, -2}, {3, 0, -20}, {0, 1, 0});
    const dataset::GroundTruth prev = dataset::groundTruth(sphere, lens, a, 0.5);
    dataset::GroundTruth now = dataset::groundTruth(sphere, lens, b, 0.5);
    dataset::flowToPrevious(now, lens, b, &prev, a, 0.5);
    const fit::Mat4 w2a = fit::invertRigid(a);
    int visible = 0;
    for (int y = 0; y < lens.height; y += 3)
        for (int x = 0; x < lens.width; x += 3) {
            const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
            if (!now.valid[i]) continue;
            // The pixel's point in the world, then in the previous camera, projected by the lens.
            const auto ray = dataset::unproject(lens, x, y);
            const double s = now.depth.at(x, y) / (*ray)[2];
            const fit::Vec3d pc{(*ray)[0] * s, (*ray)[1] * s, (*ray)[2] * s};
            fit::Vec3d pw{}, pa{};
            for (int r = 0; r < 3; ++r) pw[r] = b[r][0] * pc[0] + b[r][1] * pc[1] + b[r][2] * pc[2] + b[r][3];
            for (int r = 0; r < 3; ++r) pa[r] = w2a[r][0] * pw[0] + w2a[r][1] * pw[1] + w2a[r][2] * pw[2] + w2a[r][3];
            const auto p = dataset::project(lens, pa);
            if (!p || now.flow.at(x, y, 2) == 0) continue;
            ++visible;
            EXPECT_NEAR(now.flow.at(x, y, 0), p->u - x, 1e-3);
            EXPECT_NEAR(now.flow.at(x, y, 1), p->v - y, 1e-3);
        }
    EXPECT_GT(visible, 200);
}

}  // namespace
}  // namespace mucosa
