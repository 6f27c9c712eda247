// The physics of the endoscope's lamp and camera and of the wet film
// (docs/theory.md, "The endoscope's lamp", "The endoscope's camera", "Wet
// tissue"): the functions of shaders/common_shading.glsl and camera.glsl,
// compiled as C++, and the C++ reference renderer that applies them.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

#include "shading/glsl.hpp"

namespace mucosa {
namespace {

using namespace shading::glsl;
using shading::Param;

// A camera that changes nothing: exposure 1, no vignetting, noise, softness
// or mask, the linear response.
void neutralCamera(shading::ParamSet& p) {
    shading::setCameraIdentity(p);
}

TEST(Lamp, IrradianceFallsWithTheInverseSquareAndTheSpotProfile) {
    Material m{};
    m.lightIntensity = 400.0f;
    m.lampSourceRadius = 0.0f;
    m.lampSpread = 0.0f;
    for (float d : {2.0f, 5.0f, 20.0f, 80.0f}) EXPECT_NEAR(lampIrradiance(d, 1.0f, m) * d * d, 400.0f, 1e-2f);
    // The disk of radius a: I / (d^2 + a^2), finite at the tip.
    m.lampSourceRadius = 1.5f;
    EXPECT_NEAR(lampIrradiance(0.0f, 1.0f, m), 400.0f / 2.25f, 1e-2f);
    EXPECT_NEAR(lampIrradiance(2.0f, 1.0f, m), 400.0f / 6.25f, 1e-3f);
    // The angular profile exp(-mu (1 - cos theta)).
    m.lampSourceRadius = 0.0f;
    m.lampSpread = 2.0f;
    const float c60 = 0.5f;
    EXPECT_NEAR(lampIrradiance(10.0f, c60, m) / lampIrradiance(10.0f, 1.0f, m), std::exp(-1.0f), 1e-5f);
}

// A plane facing the scope, lit by the lamp at its tip, seen through a
// neutral camera: the centre's value at 10 mm is 4 times its value at 20 mm.
TEST(Lamp, ALitPlaneDarkensWithTheInverseSquareOfItsDistance) {
    // Fine cells: the diffuse term is per vertex (Gouraud).
    const mesh::Mesh quad = mesh::makeQuad(40.0f, 80);
    auto centre = [&](float distance) {
        shading::FrameSetup f;
        f.mode = shading::Mode::Diffuse;
        f.width = f.height = 16;
        neutralCamera(f.params);
        f.params.set(Param::LightSourceRadius, 0.01f);
        f.params.set(Param::LightSpread, 0.0f);
        f.params.set(Param::Ambient, 0.0f);
        f.params.set(Param::Wrap, 0.0f);
        f.params.set(Param::MucusOpacity, 0.0f);
        f.params.setColor(Param::BaseColor, {1, 1, 1});
        f.params.set(Param::LightIntensity, 0.5f * distance * distance);  // 0.5 at 10 mm: inside 8 bits
        const camera::Pose pose = camera::lookAt({0, 0, distance}, {0, 0, 0});
        f.view = camera::viewMatrix(pose);
        f.projection = camera::projectionMatrix(camera::Lens{}, f.width, f.height);
        f.eye = pose.position;
        f.light = pose.position;
        return f;
    };
    // The intensity scales with d^2 above, so equal pixels mean 1 / d^2 exactly.
    const image::Image8 a = shading::renderReference(quad, centre(10.0f), {});
    const image::Image8 b = shading::renderReference(quad, centre(20.0f), {});
    // Pixel (8, 8)'s centre is half a pixel off the axis in x and y: tan^2
    // of its angle t2, distance d sqrt(1 + t2), cos(N, L) = 1 / sqrt(1 + t2).
    const float t = std::tan(60.0f * std::numbers::pi_v<float> / 180.0f) / 16.0f;
    const float expected = 255.0f * 0.5f * std::pow(1.0f / (1.0f + 2.0f * t * t), 1.5f);
    EXPECT_NEAR(a.at(8, 8, 1), expected, 1.0f);
    EXPECT_EQ(a.at(8, 8, 1), b.at(8, 8, 1));
    // And with a fixed intensity: a quarter.
    shading::FrameSetup far = centre(20.0f);
    far.params.set(Param::LightIntensity, 0.5f * 100.0f);
    EXPECT_NEAR(shading::renderReference(quad, far, {}).at(8, 8, 1), expected / 4.0f, 1.0f);
}

TEST(CameraModel, ToneCurvesRoundTripAndMatchTheirStandards) {
    for (int curve : {kToneLinear, kToneBt709, kToneSrgb})
        for (float s = 0.0f; s <= 1.0f; s += 1.0f / 64.0f)
            EXPECT_NEAR(inverseToneCurve(toneCurve(s, curve), curve), s, 2e-5f) << curve << " " << s;
    // BT.709's OETF: 4.5 L below 0.018, 1.099 L^0.45 - 0.099 above; 1 -> 1.
    EXPECT_NEAR(toneCurve(0.01f, kToneBt709), 0.045f, 1e-6f);
    EXPECT_NEAR(toneCurve(0.18f, kToneBt709), 1.099f * std::pow(0.18f, 0.45f) - 0.099f, 1e-6f);
    EXPECT_NEAR(toneCurve(1.0f, kToneBt709), 1.0f, 1e-5f);
    // sRGB: 0.5 encodes to 0.7354 (IEC 61966-2-1), and decodes back.
    EXPECT_NEAR(toneCurve(0.5f, kToneSrgb), 0.7354f, 1e-4f);
    EXPECT_NEAR(srgbToLinear(toneCurve(0.5f, kToneSrgb)), 0.5f, 1e-5f);
    EXPECT_NEAR(srgbToLinear(1.0f), 1.0f, 1e-6f);
}

Camera testCamera() {
    Camera c{};
    c.exposure = 1.0f;
    c.width = 640.0f;
    c.height = 480.0f;
    c.tanHalfFovX = std::tan(60.0f * std::numbers::pi_v<float> / 180.0f);
    c.tanHalfFovY = c.tanHalfFovX * 480.0f / 640.0f;
    c.toneCurve = kToneLinear;
    c.mask = kMaskNone;
    c.saturation = 1.0f;
    c.knee = 1.0f;
    return c;
}

// The highlight knee: the identity up to k, continuous in value and slope
// there, increasing, the sensor's saturation below white at k + tanh(1) (1 - k),
// and its inverse round-trips; k = 1 is no knee.
TEST(CameraModel, HighlightKneeBendsSmoothlyAndKeepsSaturationBelowWhite) {
    const float k = 0.8f;
    EXPECT_EQ(kneeCurve(0.5f, k), 0.5f);
    EXPECT_EQ(kneeCurve(k, k), k);
    const float h = 1e-3f;
    EXPECT_NEAR((kneeCurve(k + h, k) - kneeCurve(k, k)) / h, 1.0f, 5e-3f);  // slope 1 at the knee
    float last = kneeCurve(k, k);
    for (float v = k + 0.01f; v <= 1.0f; v += 0.01f) {
        const float out = kneeCurve(v, k);
        EXPECT_GT(out, last);
        EXPECT_LT(out, v);
        EXPECT_NEAR(inverseKneeCurve(out, k), v, 1e-4f);
        last = out;
    }
    EXPECT_NEAR(kneeCurve(1.0f, k), k + std::tanh(1.0f) * (1.0f - k), 1e-6f);
    EXPECT_LT(kneeCurve(1.0f, k) * 255.0f, 245.0f);  // a saturated glint is not clipped flat to 255
    EXPECT_EQ(kneeCurve(0.95f, 1.0f), 0.95f);
    // Through the camera: a glint far over the full well shows at the knee's top.
    Camera c = testCamera();
    c.knee = k;
    const vec3 w = cameraPixel(vec3(5.0f, 5.0f, 5.0f), 320, 240, c);
    EXPECT_NEAR(w.x, kneeCurve(1.0f, k), 1e-6f);
}

// The PSF's taps: symmetric, Gaussian in the squared distance, the centre
// alone at sigma 0, and at kSoftMax a tap just beyond the 5 x 5 kernel would
// weigh under 5 % of the centre.
TEST(CameraModel, PointSpreadWeightsAreGaussianOverFiveByFive) {
    const float sigma = 1.0f;
    EXPECT_EQ(psfWeight(0, 0, sigma), 1.0f);
    EXPECT_NEAR(psfWeight(1, 0, sigma), std::exp(-0.5f), 1e-6f);
    EXPECT_NEAR(psfWeight(2, 1, sigma), std::exp(-2.5f), 1e-6f);
    EXPECT_EQ(psfWeight(-2, 1, sigma), psfWeight(1, 2, sigma));
    EXPECT_EQ(psfWeight(1, 0, 0.0f), 0.0f);
    EXPECT_EQ(psfWeight(0, 0, 0.0f), 1.0f);
    EXPECT_EQ(kSoftRadius, 2);
    EXPECT_LT(psfWeight(kSoftRadius + 1, 0, kSoftMax), 0.05f);
    EXPECT_EQ(kSoftMax, shading::info(shading::Param::Softness).max);
}

TEST(CameraModel, ColourEnhancementScalesChromaAndKeepsGreys) {
    const vec3 grey = enhanceColour(vec3(0.4f, 0.4f, 0.4f), 1.8f);
    EXPECT_NEAR(grey.x, 0.4f, 1e-6f);
    EXPECT_NEAR(grey.z, 0.4f, 1e-6f);
    const vec3 v(0.6f, 0.4f, 0.3f);
    const vec3 e = enhanceColour(v, 1.5f);
    const float luma = 0.2126f * 0.6f + 0.7152f * 0.4f + 0.0722f * 0.3f;
    EXPECT_NEAR(0.2126f * e.x + 0.7152f * e.y + 0.0722f * e.z, luma, 1e-6f);  // the luma stays
    EXPECT_NEAR(e.x - e.y, 1.5f * (v.x - v.y), 1e-6f);                        // differences scale
    const vec3 same = enhanceColour(v, 1.0f);
    EXPECT_NEAR(same.x, v.x, 1e-6f);
}

TEST(CameraModel, ExposureScalesAndTheSensorClipsToWhite) {
    Camera c = testCamera();
    c.exposure = 2.0f;  // +1 EV
    const vec3 v = cameraPixel(vec3(0.1f, 0.2f, 0.3f), 320, 240, c);
    EXPECT_NEAR(v.x, 0.2f, 1e-6f);
    EXPECT_NEAR(v.z, 0.6f, 1e-6f);
    // A glint far over the full well clips per channel to white.
    const vec3 w = cameraPixel(vec3(5.0f, 3.0f, 2.0f), 320, 240, c);
    EXPECT_EQ(w.x, 1.0f);
    EXPECT_EQ(w.y, 1.0f);
    EXPECT_EQ(w.z, 1.0f);
}

TEST(CameraModel, VignettingFollowsCosineToThePowerK) {
    Camera c = testCamera();
    c.vignettingPower = 4.0f;
    EXPECT_NEAR(vignetting(320.0f, 240.0f, c), 1.0f, 1e-6f);
    // The right edge's centre sees the field at 60 degrees: cos^4 = 1/16.
    EXPECT_NEAR(vignetting(640.0f, 240.0f, c), 1.0f / 16.0f, 1e-5f);
    // Along the diagonal, theta from tan^2 = tx^2 + ty^2.
    const float t2 = c.tanHalfFovX * c.tanHalfFovX + c.tanHalfFovY * c.tanHalfFovY;
    EXPECT_NEAR(vignetting(640.0f, 480.0f, c), 1.0f / ((1.0f + t2) * (1.0f + t2)), 1e-5f);
    // Monotonic from the centre out, and off at k = 0.
    float last = 2.0f;
    for (float x = 320.0f; x <= 640.0f; x += 16.0f) {
        const float v = vignetting(x, 240.0f, c);
        EXPECT_LT(v, last);
        last = v;
    }
    c.vignettingPower = 0.0f;
    EXPECT_EQ(vignetting(640.0f, 480.0f, c), 1.0f);
}

// Veiling glare: camera.flare x the mean radiance the sensor sees over the
// mask (after vignetting), added to every pixel; the lumen is lifted by it,
// a lit wall by the same amount.
TEST(CameraModel, VeilingGlareAddsTheFlareTimesTheFieldsMeanRadiance) {
    shading::FrameSetup f;
    f.width = 640;
    f.height = 480;
    neutralCamera(f.params);
    f.params.set(Param::Flare, 0.05f);
    constexpr int n = shading::kMeterGrid;
    std::vector<float> grid(3 * n * n, 0.0f);
    for (int j = 0; j < n; ++j)
        for (int i = n / 2; i < n; ++i) {  // the right half lit, the left half a black lumen
            float* p = &grid[3 * static_cast<std::size_t>(j * n + i)];
            p[0] = 0.4f, p[1] = 0.2f, p[2] = 0.1f;
        }
    std::array<float, 3> veil = shading::veilingGlare(grid.data(), f);
    EXPECT_NEAR(veil[0], 0.05f * 0.5f * 0.4f, 1e-6f);
    EXPECT_NEAR(veil[1], 0.05f * 0.5f * 0.2f, 1e-6f);
    EXPECT_NEAR(veil[2], 0.05f * 0.5f * 0.1f, 1e-6f);
    // On the sensor, before exposure: the black lumen reads the veil (times
    // the exposure), the wall its radiance plus the veil.
    Camera c = packCamera(f, 2.0f, glm::vec3(veil[0], veil[1], veil[2]));
    const glm::vec3 lumen = cameraPixel(glm::vec3(0.0f), 10, 240, c);
    EXPECT_NEAR(lumen.x, 2.0f * veil[0], 1e-6f);
    EXPECT_NEAR(lumen.z, 2.0f * veil[2], 1e-6f);
    EXPECT_NEAR(cameraPixel(glm::vec3(0.4f, 0.2f, 0.1f), 600, 240, c).y, 2.0f * (0.2f + veil[1]), 1e-6f);
    // Only what the mask lets through counts: with a circle of half the
    // frame's height, the lit columns beyond it add nothing.
    f.params.set(Param::Mask, 1.0f);
    f.params.set(Param::MaskRadius, 1.0f);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const float x = static_cast<float>(shading::meterPixel(i, 640)) + 0.5f - 320.0f;
            const float y = static_cast<float>(shading::meterPixel(j, 480)) + 0.5f - 240.0f;
            const bool outside = std::hypot(x, y) > 241.0f;
            for (int k = 0; k < 3; ++k) grid[3 * static_cast<std::size_t>(j * n + i) + k] = outside ? 1.0f : 0.0f;
        }
    EXPECT_EQ(shading::veilingGlare(grid.data(), f)[0], 0.0f);
    // Vignetting darkens what reaches the sensor, and so the glare.
    f.params.set(Param::Mask, 0.0f);
    std::fill(grid.begin(), grid.end(), 1.0f);
    const float flat = shading::veilingGlare(grid.data(), f)[1];
    EXPECT_NEAR(flat, 0.05f, 1e-6f);
    f.params.set(Param::Vignetting, 4.0f);
    EXPECT_LT(shading::veilingGlare(grid.data(), f)[1], 0.8f * flat);
    // No flare, no veil.
    f.params.set(Param::Flare, 0.0f);
    EXPECT_EQ(shading::veilingGlare(grid.data(), f)[1], 0.0f);
}

TEST(CameraModel, FieldOfViewMasksCoverACircleOrAnOctagon) {
    Camera c = testCamera();
    c.width = c.height = 400.0f;
    c.maskRadius = 0.9f;
    auto area = [&](int mask) {
        c.mask = mask;
        double sum = 0.0;
        for (int y = 0; y < 400; ++y)
            for (int x = 0; x < 400; ++x) sum += fovMask(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, c);
        return sum;
    };
    const double r = 0.9 * 200.0;
    EXPECT_NEAR(area(kMaskCircle), std::numbers::pi * r * r, 0.002 * std::numbers::pi * r * r);
    // A regular octagon of inradius r: 8 r^2 tan(pi / 8).
    const double octagon = 8.0 * r * r * std::tan(std::numbers::pi / 8.0);
    EXPECT_NEAR(area(kMaskOctagon), octagon, 0.002 * octagon);
    EXPECT_EQ(area(kMaskNone), 400.0 * 400.0);
}

// Poisson-Gaussian noise: the variance of pixels with mean s lies on the line
// s / fullWell + readNoise^2; the mean is unbiased.
TEST(CameraModel, SensorNoiseLiesOnItsMeanVarianceLine) {
    Camera c = testCamera();
    c.fullWell = 2000.0f;
    c.readNoise = 0.01f;
    c.frameSeed = 7;
    std::vector<double> means, vars;
    for (float s : {0.05f, 0.2f, 0.4f, 0.7f}) {
        double sum = 0.0, sum2 = 0.0;
        const int n = 200 * 200;
        for (int y = 0; y < 200; ++y)
            for (int x = 0; x < 200; ++x) {
                const double v = sensorNoise(s, pixelGaussians(x, y, c.frameSeed).y, c);
                sum += v;
                sum2 += v * v;
            }
        const double mean = sum / n, var = sum2 / n - mean * mean;
        EXPECT_NEAR(mean, s, 4.0 * std::sqrt(var / n));
        means.push_back(mean);
        vars.push_back(var);
    }
    // Least-squares line var = a mean + b.
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < means.size(); ++i) mx += means[i], my += vars[i];
    mx /= static_cast<double>(means.size());
    my /= static_cast<double>(means.size());
    double sxy = 0, sxx = 0;
    for (std::size_t i = 0; i < means.size(); ++i)
        sxy += (means[i] - mx) * (vars[i] - my), sxx += (means[i] - mx) * (means[i] - mx);
    const double a = sxy / sxx, b = my - a * mx;
    EXPECT_NEAR(a, 1.0 / 2000.0, 0.05 / 2000.0);
    EXPECT_NEAR(b, 1e-4, 0.1e-4);
    // Different frames, different patterns; the same frame, the same pattern.
    Camera d = c;
    d.frameSeed = 8;
    EXPECT_NE(pixelGaussians(5, 5, c.frameSeed).x, pixelGaussians(5, 5, d.frameSeed).x);
    EXPECT_EQ(pixelGaussians(5, 5, c.frameSeed).x, pixelGaussians(5, 5, c.frameSeed).x);
    // The three channels' deviates are independent: their correlation over
    // the frame is near 0, each channel's variance near 1.
    double cxy = 0, cxz = 0, cxx = 0;
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 200; ++x) {
            const vec3 g = pixelGaussians(x, y, 3);
            cxy += g.x * g.y, cxz += g.x * g.z, cxx += g.x * g.x;
        }
    EXPECT_NEAR(cxx / 40000.0, 1.0, 0.03);
    EXPECT_NEAR(cxy / 40000.0, 0.0, 0.02);
    EXPECT_NEAR(cxz / 40000.0, 0.0, 0.02);
}

TEST(WetFilm, FresnelIsF0AtNormalIncidenceAndOneAtGrazing) {
    shading::ParamSet p;
    p.set(Param::MucusIor, 1.33f);
    const Material m = packMaterial(p);
    EXPECT_NEAR(m.mucusF0, (0.33f / 2.33f) * (0.33f / 2.33f), 1e-7f);  // water: 0.02
    EXPECT_NEAR(fresnelSchlick(1.0f, m.mucusF0), m.mucusF0, 1e-7f);
    EXPECT_NEAR(fresnelSchlick(0.0f, m.mucusF0), 1.0f, 1e-7f);
    float last = 0.0f;
    for (float c = 1.0f; c >= 0.0f; c -= 0.05f) {
        EXPECT_GE(fresnelSchlick(c, m.mucusF0), last);
        last = fresnelSchlick(c, m.mucusF0);
    }
}

// The sheen's directional albedo, integral of f_r cos(theta_o) over the
// hemisphere, for light from `thetaI`: sheenLobe is pi f_r cos(theta_i).
double sheenAlbedo(const Material& m, double thetaI) {
    const vec3 L(static_cast<float>(std::sin(thetaI)), 0.0f, static_cast<float>(std::cos(thetaI)));
    const int nt = 400, np = 400;
    double sum = 0.0;
    for (int i = 0; i < nt; ++i) {
        const double t = (i + 0.5) * (std::numbers::pi / 2) / nt;
        for (int j = 0; j < np; ++j) {
            const double ph = (j + 0.5) * 2 * std::numbers::pi / np;
            const vec3 V(static_cast<float>(std::sin(t) * std::cos(ph)), static_cast<float>(std::sin(t) * std::sin(ph)),
                         static_cast<float>(std::cos(t)));
            const float rv = -L.x * V.x - L.y * V.y + L.z * V.z;  // R = reflect(-L, N), N = z
            const double fr = sheenLobe(L.z, V.z, rv, m) / (std::numbers::pi * std::cos(thetaI));
            sum += fr * std::cos(t) * std::sin(t) * (std::numbers::pi / 2 / nt) * (2 * std::numbers::pi / np);
        }
    }
    return sum;
}

TEST(WetFilm, TheSheenLobeConservesEnergy) {
    Material m = packMaterial(shading::ParamSet{});
    m.sheenStrength = 1.0f;
    // With F = 1 (F0 = 1) the normalised lobe reflects all of light from
    // overhead and less at oblique incidence (the horizon cuts it).
    m.mucusF0 = 1.0f;
    for (float n : {4.0f, 8.0f, 40.0f}) {
        m.sheenShininess = n;
        EXPECT_NEAR(sheenAlbedo(m, 0.0), 1.0, 0.02) << n;
        for (double t : {0.3, 0.7, 1.2, 1.5}) EXPECT_LE(sheenAlbedo(m, t), 1.0) << n << " " << t;
    }
    // The mucus film's Fresnel: at most a few percent from overhead.
    m = packMaterial(shading::ParamSet{});
    EXPECT_LE(sheenAlbedo(m, 0.0), 0.1);
    EXPECT_GT(sheenAlbedo(m, 0.0), 0.0);
}

TEST(AutoExposure, ConvergesToTheKeyWithItsTimeConstant) {
    shading::FrameSetup f;
    const float key = f.params[Param::AutoKey];
    shading::ExposureState s;
    // The first frame takes its target at once.
    EXPECT_NEAR(shading::exposureFor(f, 0.05f, s) * 0.05f, key, 1e-5f);
    // A step to 4x the light: one frame later the EV has moved by
    // 1 - exp(-dt / tau) of the 2 stops.
    f.frameIndex = 1;
    const float ev0 = s.ev;
    shading::exposureFor(f, 0.2f, s);
    const float k = 1.0f - std::exp(-(1.0f / f.params[Param::FrameRate]) / f.params[Param::Adaptation]);
    EXPECT_NEAR(s.ev - ev0, -2.0f * k, 1e-4f);
    for (int i = 2; i < 300; ++i) {
        f.frameIndex = i;
        shading::exposureFor(f, 0.2f, s);
    }
    EXPECT_NEAR(std::exp2(s.ev) * 0.2f, key, 1e-4f);
    // Fixed exposure: 2^EV whatever the meter says.
    f.params.set(Param::AutoExposure, 0);
    f.params.set(Param::ExposureEv, 1.5f);
    EXPECT_NEAR(shading::exposureFor(f, 0.7f, s), std::exp2(1.5f), 1e-6f);
    // Choices take integers only.
    EXPECT_THROW(f.params.set(Param::Mask, 1.5f), InputError);
}

}  // namespace
}  // namespace mucosa
