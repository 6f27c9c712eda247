// The clearcoat mode's equations (docs/theory.md, "Clear coat"): glTF 2.0
// Appendix B's GGX D and height-correlated Smith V, KHR_materials_clearcoat's
// layering, checked against closed forms and numeric integrals computed here
// in double precision, independently of shaders/common_shading.glsl.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <mucosa/camera/camera.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

#include "shading/glsl.hpp"

namespace mucosa {
namespace {

using namespace shading::glsl;
constexpr double kPiD = std::numbers::pi;

// Walter et al. 2007 eq. 33 and the Smith Lambda of GGX (Heitz 2014 eq. 72,
// 99): G2 = 1 / (1 + Lambda(l) + Lambda(v)), V = G2 / (4 cos_l cos_v).
double ggxD(double cosH, double alpha) {
    const double a2 = alpha * alpha, c2 = cosH * cosH;
    const double t = c2 * (a2 - 1.0) + 1.0;
    return a2 / (kPiD * t * t);
}
double lambda(double c, double alpha) {
    const double tan2 = (1.0 - c * c) / (c * c);
    return (-1.0 + std::sqrt(1.0 + alpha * alpha * tan2)) / 2.0;
}
double smithV(double cl, double cv, double alpha) {
    return 1.0 / (1.0 + lambda(cl, alpha) + lambda(cv, alpha)) / (4.0 * cl * cv);
}
double schlick(double c, double f0, double f90) {
    return f0 + (f90 - f0) * std::pow(1.0 - c, 5.0);
}

TEST(Clearcoat, GgxDistributionIsNormalisedOverProjectedArea) {
    // Int D(h) (n.h) dw_h = 1 over the hemisphere, for glossy to rough lobes.
    for (float alpha : {0.05f, 0.2f, 0.5f, 1.0f}) {
        double sum = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            // theta in [0, pi/2] with a substitution dense near the pole.
            const double s = (i + 0.5) / n, theta = s * s * kPiD / 2, dtheta = 2 * s * kPiD / 2 / n;
            sum += ggxDistribution(static_cast<float>(std::cos(theta)), alpha) * std::cos(theta) * std::sin(theta) * 2 *
                   kPiD * dtheta;
        }
        EXPECT_NEAR(sum, 1.0, 2e-3) << alpha;
        EXPECT_NEAR(ggxDistribution(1.0f, alpha), 1.0 / (kPiD * alpha * alpha), 1e-4 / (alpha * alpha));
    }
}

TEST(Clearcoat, SmithVisibilityIsTheHeightCorrelatedForm) {
    for (float alpha : {0.06f, 0.3f, 0.9f})
        for (float cl : {0.05f, 0.4f, 1.0f})
            for (float cv : {0.1f, 0.7f, 1.0f})
                EXPECT_NEAR(smithVisibility(cl, cv, alpha), smithV(cl, cv, alpha), 1e-5 * smithV(cl, cv, alpha))
                    << alpha << " " << cl << " " << cv;
    EXPECT_FLOAT_EQ(smithVisibility(1.0f, 1.0f, 0.3f), 0.25f);  // G = 1 head-on
    EXPECT_EQ(smithVisibility(0.0f, 0.0f, 0.3f), 0.0f);         // finite at grazing, no NaN
    EXPECT_FLOAT_EQ(fresnelSchlick90(1.0f, 0.04f, 0.6f), 0.04f);
    EXPECT_FLOAT_EQ(fresnelSchlick90(0.0f, 0.04f, 0.6f), 0.6f);
}

// The defaults' material, packed as the renderer does.
Material defaults() {
    return packMaterial(shading::ParamSet{});
}

TEST(Clearcoat, FlatPatchLitAndViewedHeadOnIsTheAnalyticPeak) {
    // L = V = N = Nc: H = N, every cosine 1. Base: albedo E (1 - F0_b) +
    // pi F0_b D_b(1) V_b(1,1) E + albedo Ea; coat: pi D_c(1) / 4 E; layered
    // with the coat's F(1) = 0.04.
    const Material m = defaults();
    const vec3 N(0, 0, 1), albedo(0.6f, 0.3f, 0.2f);
    const float E = 3.0f, Ea = 0.1f;
    const double rc = std::max<double>(m.clearcoatRoughness, 0.045), ac = rc * rc;
    const double rb = m.baseRoughness, ab = rb * rb;
    const double f0b = ((1.34 - 1) / (1.34 + 1)) * ((1.34 - 1) / (1.34 + 1)) * 0.6;
    const double w = 0.83;
    const vec3 got = clearcoatShading(albedo, N, N, N, N, E, Ea, m);
    for (int k = 0; k < 3; ++k) {
        const double a = albedo[k];
        const double base = a * E * (1 - f0b) + kPiD * f0b * ggxD(1, ab) * 0.25 * E + a * Ea;
        const double coat = kPiD * ggxD(1, ac) * 0.25 * E;  // = E / (4 ac^2)
        EXPECT_NEAR(got[k], base * (1 - w * 0.04) + w * 0.04 * coat, 1e-4 * coat) << k;
    }
    // The defaults put the coat's peak at the noise mode's Phong peak k_s = 2
    // (docs/rendering.md): w F0 / (4 alpha^2) = 0.83 x 0.04 / (4 x 0.254^4).
    EXPECT_NEAR(w * 0.04 / (4 * ac * ac), 2.0, 0.01);
}

TEST(Clearcoat, TheCoatAttenuatesTheBaseByItsFresnelAtNcDotV) {
    Material m = defaults();
    const vec3 N(0, 0, 1), albedo(0.5f);
    // A grazing view (strong Fresnel, so the test has teeth): the result is
    // base (1 - w F(Nc.V)) + w F(Nc.V) pi D V cos_l E, the coat's lobe
    // computed here with the closed forms above.
    const vec3 L = normalize(vec3(0.9f, 0, 1)), V = normalize(vec3(0, 0.99f, 0.12f));
    const float alpha = ggxAlpha(m.clearcoatRoughness);
    m.clearcoat = 0.0f;
    const vec3 base = clearcoatShading(albedo, N, N, L, V, 1.0f, 0.0f, m);
    const vec3 H = normalize(L + V);
    const double lobe = kPiD * ggxD(H.z, alpha) * smithV(L.z, V.z, alpha) * L.z;
    const double F = schlick(V.z, 0.04, 1.0);
    EXPECT_GT(F, 0.5);
    for (float w : {0.25f, 1.0f}) {
        m.clearcoat = w;
        const vec3 coated = clearcoatShading(albedo, N, N, L, V, 1.0f, 0.0f, m);
        EXPECT_NEAR(coated.x, base.x * (1.0 - w * F) + w * F * lobe, 1e-4 * base.x) << w;
    }
    // A coat normal tilted towards V lowers F(Nc.V): the base shows more
    // (the attenuation reads the coat's normal, not the geometry's).
    m.clearcoat = 1.0f;
    const vec3 Nc = normalize(N + V * 0.5f);
    const vec3 tilted = clearcoatShading(albedo, N, Nc, L, V, 1.0f, 0.0f, m);
    const vec3 flat = clearcoatShading(albedo, N, N, L, V, 1.0f, 0.0f, m);
    EXPECT_GT(tilted.x, flat.x * 1.1f);
}

TEST(Clearcoat, TheCoatsDirectionalAlbedoIsItsFresnelAndNoMore) {
    // Radiance / (pi E) is BRDF x cos; integrated over the lamp's directions
    // with an albedo 0 base it is the coat's directional albedo: w F(N.V)
    // times GGX's single-scattering energy (<= 1, ~1 when glossy).
    Material m = defaults();
    m.clearcoat = 1.0f;
    m.sheenStrength = 0.0f;  // no base specular: the base is black
    const vec3 N(0, 0, 1);
    for (float roughness : {0.2f, 0.254f, 0.6f})
        for (float viewDeg : {0.0f, 40.0f}) {
            m.clearcoatRoughness = roughness;
            const vec3 V(std::sin(viewDeg * float(kPiD) / 180), 0, std::cos(viewDeg * float(kPiD) / 180));
            double sum = 0, lobe = 0;  // the shader's and the closed forms' (above) integrals
            const double alpha = ggxAlpha(roughness);
            const int nt = 1500, np = 720;
            for (int i = 0; i < nt; ++i) {
                const double s = (i + 0.5) / nt, theta = s * s * kPiD / 2, dtheta = 2 * s * kPiD / 2 / nt;
                for (int j = 0; j < np; ++j) {
                    const double phi = (j + 0.5) * 2 * kPiD / np;
                    const vec3 L(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                                 float(std::cos(theta)));
                    const vec3 c = clearcoatShading(vec3(0.0f), N, N, L, V, 1.0f, 0.0f, m);
                    const double dw = std::sin(theta) * dtheta * (2 * kPiD / np);
                    sum += c.x / kPiD * dw;
                    const vec3 H = normalize(L + V);
                    lobe += ggxD(H.z, alpha) * smithV(L.z, V.z, alpha) * L.z * dw;
                }
            }
            const double F = schlick(std::cos(viewDeg * kPiD / 180), 0.04, 1.0);
            // Single-scattering GGX keeps 0.99 of the energy when glossy, 0.82
            // at alpha 0.36 (r 0.6) head-on.
            EXPECT_NEAR(sum, F * lobe, 1e-3 * F) << roughness << " " << viewDeg;
            EXPECT_LE(lobe, 1.001) << roughness << " " << viewDeg;
            EXPECT_GE(lobe, roughness < 0.3f ? 0.97 : 0.75) << roughness << " " << viewDeg;
        }
}

TEST(Clearcoat, RoughnessIsBoundedForThePointLamp) {
    EXPECT_FLOAT_EQ(ggxAlpha(0.3f), 0.09f);
    EXPECT_FLOAT_EQ(ggxAlpha(0.0f), 0.045f * 0.045f);  // finite peak: no delta lobe
    EXPECT_FLOAT_EQ(ggxAlpha(1.0f), 1.0f);
}

// Through the C++ reference renderer: the coat follows the map, the base not.
TEST(Clearcoat, TheCoatFollowsTheMapAndWithoutItTheMapChangesNothing) {
    const mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    reflectance::MapParams p = reflectance::findPreset("bronchial").params;
    p.size = 128;
    const image::Image8 map =
        reflectance::encodeNormals8(reflectance::heightField(p), p.strength, reflectance::Edges::Wrap);
    shading::FrameSetup f;
    camera::Lens lens;
    lens.fovDeg = 60.0f;
    const camera::Pose pose = camera::lookAt({0.0f, -4.0f, 30.0f}, {0, 0, 0});
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, 160, 120);
    f.eye = pose.position;
    f.light = pose.position;
    f.mode = shading::Mode::Clearcoat;
    f.width = 160;
    f.height = 120;
    shading::setCameraIdentity(f.params);
    f.params.set(shading::Param::ExposureEv, -2.0f);
    shading::Textures withMap, flat;
    withMap.reflectance = {&map, shading::Filter::Linear, shading::Wrap::Repeat};
    auto differing = [](const image::Image8& a, const image::Image8& b) {
        int n = 0;
        for (int y = 0; y < a.height(); ++y)
            for (int x = 0; x < a.width(); ++x)
                for (int k = 0; k < 3; ++k) n += std::abs(int(a.at(x, y, k)) - int(b.at(x, y, k))) > 4;
        return n;
    };
    const image::Image8 bumpy = shading::renderReference(quad, f, withMap);
    const image::Image8 smooth = shading::renderReference(quad, f, flat);
    EXPECT_GT(differing(bumpy, smooth), 160 * 120 / 10);
    f.params.set(shading::Param::Clearcoat, 0.0f);
    EXPECT_EQ(differing(shading::renderReference(quad, f, withMap), shading::renderReference(quad, f, flat)), 0);
}

// clearcoat-procedural is the clearcoat mode with the coat's normal from the
// run-time noise: without the noise it is the flat coat exactly, without the
// coat the noise changes nothing (the base lies on the geometry's normal), and
// in texture space it draws what the clearcoat mode draws from the map made of
// the same noise (the procedural path follows the map's central-difference
// response, ProceduralSetup::texels), not a mirrored or rotated copy of it.
TEST(Clearcoat, ProceduralCoatIsTheMapsCoatFromTheSameNoise) {
    const mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    // Broad bumps, all below the map's Nyquist frequency, so that the map's
    // glints and the noise's can be told apart pixel by pixel (the mutations
    // measured: the noise's v mirrored or T and B swapped: mean 3.5-3.6/255
    // against the map's frame, as far as the flat coat; as built: 0.39/255).
    reflectance::MapParams p = reflectance::findPreset("serosa").params;
    p.size = 256;
    const image::Image8 map =
        reflectance::encodeNormals8(reflectance::heightField(p), p.strength, reflectance::Edges::Wrap);
    shading::FrameSetup f;
    camera::Lens lens;
    lens.fovDeg = 30.0f;
    const camera::Pose pose = camera::lookAt({0.0f, -1.0f, 30.0f}, {0, 0, 0});
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, 160, 120);
    f.eye = pose.position;
    f.light = pose.position;
    f.width = 160;
    f.height = 120;
    f.specularAA = false;
    f.procedural.noise = p.noise;
    f.procedural.strength = static_cast<float>(p.strength);
    f.procedural.texels = p.size;
    f.params.set(shading::Param::NoiseScale, 12.0f);
    shading::setCameraIdentity(f.params);
    f.params.set(shading::Param::ExposureEv, -2.0f);
    shading::Textures withMap, flat;
    withMap.reflectance = {&map, shading::Filter::Linear, shading::Wrap::Repeat};
    auto render = [&](shading::Mode mode, const shading::Textures& t, shading::NoiseSpace space) {
        shading::FrameSetup g = f;
        g.mode = mode;
        g.procedural.space = space;
        return shading::renderReference(quad, g, t);
    };
    struct Diff {
        int maxDiff = 0;
        int over = 0;     // channel values more than 4/255 apart
        double mean = 0;  // mean absolute difference per channel
    };
    auto diff = [](const image::Image8& a, const image::Image8& b) {
        Diff d;
        for (int y = 0; y < a.height(); ++y)
            for (int x = 0; x < a.width(); ++x)
                for (int k = 0; k < 3; ++k) {
                    const int e = std::abs(int(a.at(x, y, k)) - int(b.at(x, y, k)));
                    d.maxDiff = std::max(d.maxDiff, e);
                    d.over += e > 4;
                    d.mean += e;
                }
        d.mean /= 3.0 * a.width() * a.height();
        return d;
    };
    const int channels = 3 * 160 * 120;
    const image::Image8 flatCoat = render(shading::Mode::Clearcoat, flat, shading::NoiseSpace::Uv);
    for (const shading::NoiseSpace space : {shading::NoiseSpace::Uv, shading::NoiseSpace::Object}) {
        const char* name = space == shading::NoiseSpace::Uv ? "uv" : "object";
        const image::Image8 bumpy = render(shading::Mode::ClearcoatProcedural, flat, space);
        const Diff moved = diff(bumpy, flatCoat);
        std::printf("clearcoat-procedural (%s) vs the flat coat: %d of %d channels > 4/255 apart\n", name, moved.over,
                    channels);
        EXPECT_GT(moved.over, channels / 10) << name;
        // No noise: the flat coat (object space renormalises N once more: 1/255).
        shading::FrameSetup g = f;
        f.procedural.strength = 0.0f;
        EXPECT_LE(diff(render(shading::Mode::ClearcoatProcedural, flat, space), flatCoat).maxDiff, 1) << name;
        // No coat: the noise changes nothing.
        f = g;
        f.params.set(shading::Param::Clearcoat, 0.0f);
        EXPECT_EQ(
            diff(render(shading::Mode::ClearcoatProcedural, flat, space), render(shading::Mode::Clearcoat, flat, space))
                .maxDiff,
            0)
            << name;
        f = g;
    }
    // Texture space: the map's coat from the same noise, glint for glint.
    const image::Image8 fromMap = render(shading::Mode::Clearcoat, withMap, shading::NoiseSpace::Uv);
    const Diff same = diff(render(shading::Mode::ClearcoatProcedural, flat, shading::NoiseSpace::Uv), fromMap);
    const Diff none = diff(flatCoat, fromMap);
    std::printf(
        "clearcoat-procedural (uv) vs clearcoat with the map: mean %.3f/255, %d channels > 4/255 (flat coat: "
        "mean %.3f/255, %d)\n",
        same.mean, same.over, none.mean, none.over);
    EXPECT_LT(same.mean, 0.25 * none.mean);
    EXPECT_LT(same.over, none.over / 4);
}

}  // namespace
}  // namespace mucosa
