// Rendering through a lens (Renderer::setLensRays): the frame drawn into one
// wide face (a lens within 70 degrees of its axis) or a cube map around the
// camera, and resampled along every pixel's ray. Checked
// on an analytic scene: a plane facing the camera whose texture coordinates
// are its world position (the `uv` debug mode shows them, in a half-float
// target), so every pixel says which point of the plane it sees; that point,
// projected with the lens's exact model, must land back on the pixel.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/camera/camera.hpp>
#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/shading/params.hpp>

#include "render_test_support.hpp"

namespace mucosa {
namespace {

constexpr float kPlaneDistance = 10.0f;  // mm, the camera on +z looking down -z at the z = 0 plane
constexpr float kPeriod = 2.0f;          // mm of the plane per unit of u and v (the uv mode shows fract())

// A frame from `pose` with the lamp at the eye; `lens` gives the near and far
// planes (and the field of view when no rays are set).
shading::FrameSetup frameAt(const camera::Pose& pose, const camera::Lens& lens, int w, int h, shading::Mode mode) {
    shading::FrameSetup f;
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, w, h);
    f.eye = pose.position;
    f.light = pose.position;
    f.mode = mode;
    f.width = w;
    f.height = h;
    return f;
}

struct Reprojection {
    double rms = 0, p99 = 0;  // pixels
    std::size_t checked = 0, seen = 0;
};

// Renders the plane through `lens` (or the pinhole frame when `rays` is
// empty) and measures where the points it shows project back.
Reprojection renderPlane(const dataset::Lens& lens, bool throughLens, bool clipToMask = false) {
    test::glContext();
    render::Renderer renderer;
    mesh::Mesh plane = mesh::makeQuad(400.0f, 16);
    for (std::size_t i = 0; i < plane.positions.size(); ++i)
        plane.uvs[i] = {plane.positions[i][0] / kPeriod, plane.positions[i][1] / kPeriod};
    renderer.setMesh(plane);
    const int w = lens.width, h = lens.height;
    image::ImageF rays = dataset::rayImage(lens);
    if (clipToMask) render::clipRaysToMask(rays, shading::ParamSet());  // the default circle: black beyond
    if (throughLens) renderer.setLensRays(rays);
    const camera::Pose pose = camera::lookAt({0, 0, kPlaneDistance}, {0, 0, 0}, {0, 1, 0});
    camera::Lens pinhole;
    pinhole.fovDeg = 2.0f * static_cast<float>(std::atan(0.5 * std::max(w, h) / lens.fx) * 180.0 / M_PI);
    pinhole.nearMm = 0.5f;
    pinhole.farMm = 2000.0f;
    const shading::FrameSetup f = frameAt(pose, pinhole, w, h, shading::Mode::Uv);
    render::Framebuffer fb(w, h, render::ColorFormat::Rgba16F);
    fb.bind();
    renderer.draw(f);
    const image::ImageF uv = fb.readRgbLinear();

    Reprojection out;
    std::vector<double> errors;
    double sum = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const auto ray = dataset::unproject(lens, x, y), next = dataset::unproject(lens, x + 1, y);
            if (!ray || !next || (*ray)[2] < 0.25 || (*next)[2] < 0.25) continue;  // within ~75 degrees
            if (rays.at(x, y, 2) == 0.0f) continue;                                // beyond the mask
            ++out.seen;
            // Where a pixel spans more than 1/8 of the pattern's period, its
            // sawtooth is not resolved (the frame is not supersampled).
            const double footprint = kPlaneDistance * std::hypot((*next)[0] / (*next)[2] - (*ray)[0] / (*ray)[2],
                                                                 (*next)[1] / (*next)[2] - (*ray)[1] / (*ray)[2]);
            if (footprint > kPeriod / 8) continue;
            // The point the pixel's centre sees, and the fract() the frame should show there.
            const double t = kPlaneDistance / (*ray)[2];
            const double wx = (*ray)[0] * t, wy = -(*ray)[1] * t;
            double shown[2] = {uv.at(x, y, 0), uv.at(x, y, 1)}, world[2] = {wx, wy};
            bool nearWrap = false;
            for (int k = 0; k < 2; ++k) {
                const double expected = world[k] / kPeriod - std::floor(world[k] / kPeriod);
                nearWrap |= expected < 0.1 || expected > 0.9;  // bilinear filtering across the sawtooth's jump
                double d = shown[k] - expected;
                d -= std::round(d);
                world[k] += d * kPeriod;  // the point shown
            }
            if (nearWrap) continue;
            const auto p = dataset::project(lens, {world[0], -world[1], kPlaneDistance});
            const double e = p ? std::hypot(p->u - x, p->v - y) : 1e9;
            errors.push_back(e);
            sum += e * e;
        }
    out.checked = errors.size();
    if (errors.empty()) return out;
    out.rms = std::sqrt(sum / static_cast<double>(errors.size()));
    std::sort(errors.begin(), errors.end());
    out.p99 = errors[static_cast<std::size_t>(0.99 * static_cast<double>(errors.size() - 1))];
    return out;
}

TEST(LensRender, AFisheyeFrameShowsWhatItsModelSeesAtEveryPixel) {
    const dataset::Lens fisheye = dataset::equidistantFisheye(200, 160, 160.0);
    const Reprojection r = renderPlane(fisheye, true);
    std::printf("equidistant fisheye 160 deg: %zu pixels checked of %zu, rms %.3f px, p99 %.3f px\n", r.checked, r.seen,
                r.rms, r.p99);
    EXPECT_GT(r.checked, 0.3 * static_cast<double>(r.seen));
    EXPECT_LE(r.rms, 0.05);
    EXPECT_LE(r.p99, 0.1);
}

// A bronchoscope's fisheye, 120 degrees across its image circle: its corners
// see 85 degrees out, but the scope's mask hides them, and without them it is
// drawn in one wide face, as exactly as through the cube.
TEST(LensRender, ABronchoscopesFisheyeIsDrawnInOneWideFace) {
    const dataset::Lens scope = dataset::equidistantFisheye(200, 200, 120.0, dataset::FieldOfViewSpan::Horizontal);
    image::ImageF rays = dataset::rayImage(scope);
    EXPECT_FALSE(render::drawnInOneFace(rays));
    render::clipRaysToMask(rays, shading::ParamSet());
    EXPECT_TRUE(render::drawnInOneFace(rays));
    // Only the corners beyond the circle (and the PSF's reach) lost their rays.
    int kept = 0;
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 200; ++x) {
            const bool ray = rays.at(x, y, 2) != 0.0f;
            kept += ray;
            const double r = std::hypot(x + 0.5 - 100.0, y + 0.5 - 100.0);
            if (r < 100.0) EXPECT_TRUE(ray) << x << ", " << y;
            if (r > 104.0) EXPECT_FALSE(ray) << x << ", " << y;
        }
    EXPECT_NEAR(kept, M_PI * 102.0 * 102.0, 0.02 * M_PI * 102.0 * 102.0);
    EXPECT_FALSE(render::drawnInOneFace(dataset::rayImage(dataset::equidistantFisheye(200, 160, 160.0))));
    const Reprojection r = renderPlane(scope, true, true);
    std::printf("equidistant fisheye 120 deg in one face: %zu pixels checked of %zu, rms %.3f px, p99 %.3f px\n",
                r.checked, r.seen, r.rms, r.p99);
    EXPECT_GT(r.checked, 0.3 * static_cast<double>(r.seen));
    EXPECT_LE(r.rms, 0.05);
    EXPECT_LE(r.p99, 0.1);
}

TEST(LensRender, AKannalaBrandtLensAndAPinholeThroughTheirFacesAgreeWithTheirModels) {
    dataset::Lens kb = dataset::equidistantFisheye(160, 120, 150.0);
    kb.k1 = -0.02, kb.k2 = 0.004, kb.k3 = -0.0005;
    dataset::validateLens(kb);
    const Reprojection r = renderPlane(kb, true);
    std::printf("Kannala-Brandt: %zu pixels checked, rms %.3f px, p99 %.3f px\n", r.checked, r.rms, r.p99);
    EXPECT_LE(r.rms, 0.05);
    EXPECT_LE(r.p99, 0.1);
    // The renderer's own pinhole frame, through its rays (one wide face) and drawn directly.
    const dataset::Lens pin = dataset::fromIntrinsics(dataset::intrinsicsOf(camera::Lens{}, 160, 120));
    const Reprojection face = renderPlane(pin, true), direct = renderPlane(pin, false);
    std::printf("pinhole: through one face rms %.3f px, p99 %.3f; drawn directly rms %.3f, p99 %.3f\n", face.rms,
                face.p99, direct.rms, direct.p99);
    EXPECT_LE(face.rms, 0.05);
    EXPECT_LE(direct.rms, 0.05);
}

// A photographic mode through the camera (exposure, noise, mask): the
// pinhole's own rays (one wide face) give the pinhole frame.
TEST(LensRender, APhotographicFrameThroughThePinholesRaysIsThePinholeFrame) {
    test::glContext();
    render::Renderer renderer;
    renderer.setMesh(mesh::makeTube(6.0f, 80.0f, 96, 160));
    const int w = 160, h = 120;
    const camera::Pose pose = camera::lookAt({0, 0, -2}, {0.5f, 0, -20}, {0, 1, 0});
    const camera::Lens lens;
    const shading::FrameSetup f = frameAt(pose, lens, w, h, shading::Mode::Noise);
    ASSERT_FALSE(shading::cameraIsIdentity(f.params));
    render::Framebuffer fb(w, h);
    fb.bind();
    renderer.draw(f);
    const image::Image8 direct = fb.readRgb();
    renderer.setLensRays(dataset::rayImage(dataset::fromIntrinsics(dataset::intrinsicsOf(lens, w, h))));
    render::Framebuffer fresh(w, h);  // nothing of the first frame in it
    fresh.bind();
    renderer.draw(f);
    const image::Image8 cube = fresh.readRgb();
    const test::DiffStats d = test::diff(direct, cube, 12);
    std::printf("pinhole frame through the cube: mean %.2f/255, %.2f%% of pixels over 12/255\n", d.meanAbs,
                100 * d.fractionOver);
    double mean = 0;
    for (std::size_t i = 0; i < direct.size(); ++i) mean += direct.data()[i];
    EXPECT_GT(mean / static_cast<double>(direct.size()), 20.0);  // a lit frame, not a black one
    EXPECT_LE(d.meanAbs, 2.0);
    EXPECT_LE(d.fractionOver, 0.02);
    if (d.meanAbs > 2.0) test::writeComparison("lens_pinhole_cube", cube, direct);
}

// The sub-surface scattering runs on the perspective images a lens reads:
// the one wide face gives the pinhole frame's scattering, and through a cube
// map (a 160-degree fisheye) it moves light without making or losing any.
TEST(LensRender, ScatteringThroughALensIsThePinholesAndKeepsTheLight) {
    test::glContext();
    render::Renderer renderer;
    renderer.setMesh(mesh::makeTube(6.0f, 80.0f, 96, 160));
    const int w = 160, h = 120;
    const camera::Pose pose = camera::lookAt({0, 0, -2}, {3.0f, 0, -20}, {0, 1, 0});
    const camera::Lens lens;
    auto draw = [&](const shading::FrameSetup& f) {
        render::Framebuffer fb(w, h);
        fb.bind();
        renderer.draw(f);
        return fb.readRgb();
    };
    shading::FrameSetup f = frameAt(pose, lens, w, h, shading::Mode::Noise);
    f.params.setColor(shading::Param::Scatter, {0.5f, 0.3f, 0.2f});
    f.params.set(shading::Param::ScatterShare, 1.0f);
    f.params.set(shading::Param::AutoExposure, 0.0f);  // the same exposure with and without
    f.params.set(shading::Param::FullWell, 0.0f);
    f.params.set(shading::Param::ReadNoise, 0.0f);
    shading::FrameSetup sharp = f;
    sharp.params.set(shading::Param::ScatterShare, 0.0f);
    renderer.setLensRays({});
    const image::Image8 direct = draw(f), directSharp = draw(sharp);
    EXPECT_GT(test::diff(direct, directSharp, 4).fractionOver, 0.05) << "the scattering must show";
    renderer.setLensRays(dataset::rayImage(dataset::fromIntrinsics(dataset::intrinsicsOf(lens, w, h))));
    const image::Image8 face = draw(f);
    const test::DiffStats d = test::diff(direct, face, 12);
    if (d.meanAbs > 2.0) test::writeComparison("lens_scatter_face", face, direct);
    std::printf("scattered pinhole frame through one face: mean %.2f/255, %.2f%% of pixels over 12/255\n", d.meanAbs,
                100 * d.fractionOver);
    EXPECT_LE(d.meanAbs, 2.0);
    EXPECT_LE(d.fractionOver, 0.02);
    image::ImageF wide = dataset::rayImage(dataset::equidistantFisheye(w, h, 160.0));
    ASSERT_FALSE(render::drawnInOneFace(wide));
    renderer.setLensRays(wide);
    const image::Image8 cube = draw(f), cubeSharp = draw(sharp);
    EXPECT_GT(test::diff(cube, cubeSharp, 4).fractionOver, 0.05) << "the scattering must show through the cube";
    auto mean = [](const image::Image8& img) {
        double m = 0;
        for (std::size_t i = 0; i < img.size(); ++i) m += img.data()[i];
        return m / static_cast<double>(img.size());
    };
    std::printf("through the cube: mean level %.2f scattered, %.2f sharp\n", mean(cube), mean(cubeSharp));
    EXPECT_GT(mean(cubeSharp), 20.0);
    EXPECT_NEAR(mean(cube) / mean(cubeSharp), 1.0, 0.03);
}

// A lens whose every ray the mask removed sees nothing: a black frame.
TEST(LensRender, RaysThatSeeNothingGiveABlackFrame) {
    test::glContext();
    render::Renderer renderer;
    renderer.setMesh(mesh::makeQuad(10.0f, 2));
    renderer.setLensRays(image::ImageF(40, 30, 3));
    shading::FrameSetup f;
    f.view = camera::viewMatrix(camera::lookAt({0, 0, 5}, {0, 0, 0}));
    f.projection = camera::projectionMatrix(camera::Lens{}, 40, 30);
    f.mode = shading::Mode::Uv;
    f.width = 40;
    f.height = 30;
    render::Framebuffer fb(40, 30);
    fb.bind();
    renderer.draw(f);
    const image::Image8 img = fb.readRgb();
    EXPECT_EQ(std::count(img.data(), img.data() + img.size(), std::uint8_t{0}), static_cast<long>(img.size()));
}

TEST(LensRender, RaysForAnotherSizeAreRefused) {
    test::glContext();
    render::Renderer renderer;
    renderer.setMesh(mesh::makeQuad(10.0f, 2));
    renderer.setLensRays(dataset::rayImage(dataset::equidistantFisheye(64, 48, 120.0)));
    EXPECT_GT(renderer.cubeFaceSize(), 16);
    shading::FrameSetup f;
    f.view = camera::viewMatrix(camera::lookAt({0, 0, 5}, {0, 0, 0}));
    f.projection = camera::projectionMatrix(camera::Lens{}, 80, 60);
    f.mode = shading::Mode::Uv;
    render::Framebuffer fb(80, 60);
    fb.bind();
    EXPECT_THROW(renderer.draw(f), InputError);
    renderer.setLensRays({});
    EXPECT_EQ(renderer.cubeFaceSize(), 0);
    EXPECT_NO_THROW(renderer.draw(f));
}

}  // namespace
}  // namespace mucosa
