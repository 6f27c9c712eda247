// The generated tissue texture (docs/theory.md, "Tissue texture") and
// patient variation ("Patient variation"): tileable, deterministic, coloured
// like white-light bronchoscopy, with connected, branching, tapering,
// longitudinal vessels that fade with depth; appearance draws inside their
// stated ranges; the scene key and the CLI option.
#include <mucosa/reflectance/tissue_texture.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/reflectance/appearance.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/params.hpp>

#include "test_support.hpp"

using namespace mucosa;
using namespace mucosa::reflectance;

namespace {

constexpr double kDeg = 180 / std::numbers::pi;

std::array<double, 3> labAt(const image::Image8& img, int x, int y) {
    return srgbToLab({img.at(x, y, 0) / 255.0, img.at(x, y, 1) / 255.0, img.at(x, y, 2) / 255.0});
}

// Mean absolute difference (all channels) between columns x and x+1
// (wrapping) or rows y and y+1.
double columnStep(const image::Image8& img, int x) {
    const int n = img.width(), x1 = (x + 1) % n;
    double s = 0;
    for (int y = 0; y < img.height(); ++y)
        for (int c = 0; c < 3; ++c) s += std::abs(img.at(x, y, c) - img.at(x1, y, c));
    return s / (3.0 * img.height());
}
double rowStep(const image::Image8& img, int y) {
    const int n = img.height(), y1 = (y + 1) % n;
    double s = 0;
    for (int x = 0; x < img.width(); ++x)
        for (int c = 0; c < 3; ++c) s += std::abs(img.at(x, y, c) - img.at(x, y1, c));
    return s / (3.0 * img.width());
}

// The seam steps (last column/row to the first) against the largest
// interior step: a texture that tiles is no more discontinuous at its edges
// than anywhere inside.
void expectSeamless(const image::Image8& img, const std::string& what) {
    double interiorCol = 0, interiorRow = 0;
    for (int i = 0; i + 1 < img.width(); ++i) {
        interiorCol = std::max(interiorCol, columnStep(img, i));
        interiorRow = std::max(interiorRow, rowStep(img, i));
    }
    EXPECT_LE(columnStep(img, img.width() - 1), interiorCol) << what << ": the u seam";
    EXPECT_LE(rowStep(img, img.height() - 1), interiorRow) << what << ": the v seam";
}

// -ln(T) per channel: what the vessels remove, from a texture with vessels
// and the same one without (the colour fields do not depend on the vessels).
std::vector<std::array<double, 3>> vesselAbsorbance(const TissueParams& p, int size) {
    TissueParams bare = p;
    bare.vesselDensity = 0;
    const image::Image8 with = tissueTexture(p, size), without = tissueTexture(bare, size);
    auto lin = [](int v) {
        const double s = (v + 0.5) / 256.0;  // mid-code, so 0 stays finite
        return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
    };
    std::vector<std::array<double, 3>> A(static_cast<std::size_t>(size) * size);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
            for (int c = 0; c < 3; ++c)
                A[static_cast<std::size_t>(y) * size + x][c] =
                    std::max(0.0, -std::log(lin(with.at(x, y, c)) / lin(without.at(x, y, c))));
    return A;
}

// Children of every segment.
std::vector<std::vector<int>> children(const std::vector<VesselSegment>& s) {
    std::vector<std::vector<int>> ch(s.size());
    for (std::size_t i = 0; i < s.size(); ++i)
        if (s[i].parent >= 0) ch[static_cast<std::size_t>(s[i].parent)].push_back(static_cast<int>(i));
    return ch;
}

double angleBetween(const VesselSegment& a, const VesselSegment& b) {
    const double ax = a.x1 - a.x0, ay = a.y1 - a.y0, bx = b.x1 - b.x0, by = b.y1 - b.y0;
    const double c = (ax * bx + ay * by) / std::hypot(ax, ay) / std::hypot(bx, by);
    return std::acos(std::clamp(c, -1.0, 1.0)) * kDeg;
}

// Length-weighted mean |cos| of the angle between the vessels and v.
double longitudinality(const std::vector<VesselSegment>& segs) {
    double w = 0, c = 0;
    for (const VesselSegment& s : segs) {
        const double dx = s.x1 - s.x0, dy = s.y1 - s.y0, len = std::hypot(dx, dy);
        w += len;
        c += std::abs(dy);
    }
    return c / w;
}

}  // namespace

TEST(TissueColour, LabConversionMatchesTheReferenceValues) {
    // sRGB white and primaries in CIELAB (D65): Lindbloom's calculator / CIE 15:2004.
    const auto white = srgbToLab({1, 1, 1});
    EXPECT_NEAR(white[0], 100, 0.01);
    EXPECT_NEAR(white[1], 0, 0.01);
    EXPECT_NEAR(white[2], 0, 0.01);
    const auto red = srgbToLab({1, 0, 0});
    EXPECT_NEAR(red[0], 53.24, 0.02);
    EXPECT_NEAR(red[1], 80.09, 0.05);
    EXPECT_NEAR(red[2], 67.20, 0.05);
    const auto blue = srgbToLab({0, 0, 1});
    EXPECT_NEAR(blue[0], 32.30, 0.02);
    EXPECT_NEAR(blue[1], 79.19, 0.05);
    EXPECT_NEAR(blue[2], -107.86, 0.05);
    // Round trip through the gamut's interior (the published 7-digit
    // matrices are inverse to ~1e-5).
    for (const std::array<double, 3> lab : {std::array<double, 3>{64, 24, 26}, {40, -10, 30}, {80, 5, -20}}) {
        const auto back = srgbToLab(labToSrgb(lab));
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[c], lab[c], 1e-4);
    }
}

TEST(TissueTexture, OppositeEdgesContinueInUAndV) {
    for (std::uint64_t seed : {7u, 11u, 12345u}) expectSeamless(tissueTexture(256, seed), "texture");
    // The vessels alone (no colour fields) and the colour fields alone.
    TissueParams vessels;
    vessels.hueVariation = vessels.chromaVariation = vessels.lightnessVariation = vessels.mottle = 0;
    vessels.vesselDensity = 3;
    expectSeamless(tissueTexture(vessels, 256), "vessels only");
    TissueParams colour;
    colour.vesselDensity = 0;
    expectSeamless(tissueTexture(colour, 256), "colour only");
    // And the vessel network crosses the seams (so the test above saw vessels there).
    const auto segs = vesselNetwork(vessels);
    EXPECT_TRUE(std::any_of(segs.begin(), segs.end(), [&](const VesselSegment& s) {
        return s.y1 < 0 || s.y1 > vessels.tileMm || s.x1 < 0 || s.x1 > vessels.tileMm;
    }));
}

TEST(TissueTexture, SameSeedSameTextureOtherSeedsDiffer) {
    EXPECT_EQ(tissueTexture(128, 3), tissueTexture(128, 3));
    EXPECT_EQ(tissueTexture(128), tissueTexture(TissueParams{}, 128));  // the old signature: the defaults
    const image::Image8 a = tissueTexture(128, 3), b = tissueTexture(128, 4);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.size(); ++i) differ += a.data()[i] != b.data()[i];
    EXPECT_GT(differ, a.size() / 2);
}

TEST(TissueTexture, ColourIsWhiteLightBronchoscopyMucosaAndVaries) {
    for (std::uint64_t seed : {1u, 7u, 99u}) {
        const image::Image8 img = tissueTexture(256, seed);
        // Mean a*, b*, and the hue of 16 x 16 blocks (what a frame's patches show).
        constexpr int kBlocks = 16;
        const int bs = img.width() / kBlocks;
        std::vector<double> blockHue;
        double sa = 0, sb = 0, sL = 0;
        for (int by = 0; by < kBlocks; ++by)
            for (int bx = 0; bx < kBlocks; ++bx) {
                double a = 0, b = 0;
                for (int y = by * bs; y < (by + 1) * bs; ++y)
                    for (int x = bx * bs; x < (bx + 1) * bs; ++x) {
                        const auto lab = labAt(img, x, y);
                        a += lab[1];
                        b += lab[2];
                        sL += lab[0];
                    }
                sa += a;
                sb += b;
                blockHue.push_back(std::atan2(b, a) * kDeg);
            }
        const double n = static_cast<double>(img.width()) * img.height();
        const double hue = std::atan2(sb, sa) * kDeg;
        EXPECT_GE(hue, 34) << seed;
        EXPECT_LE(hue, 46) << seed;
        EXPECT_NEAR(sb / n, 23, 5) << seed;
        EXPECT_NEAR(sL / n, 63, 5) << seed;
        const double nb = static_cast<double>(blockHue.size());
        const double mean = std::accumulate(blockHue.begin(), blockHue.end(), 0.0) / nb;
        double var = 0;
        for (double h : blockHue) var += (h - mean) * (h - mean);
        const double sd = std::sqrt(var / nb);
        std::printf("seed %llu: hue of the mean %.1f deg, b* %.1f, L* %.1f, sd of block hues %.1f deg\n",
                    static_cast<unsigned long long>(seed), hue, sb / n, sL / n, sd);
        EXPECT_GT(sd, 4.0) << seed;   // varies within a frame ...
        EXPECT_LT(sd, 12.0) << seed;  // ... as mucosa does, not as a rainbow
    }
}

TEST(TissueTexture, ToneSpansGreyPinkToOrangeYellow) {
    auto meanLch = [](const TissueParams& p) {
        const image::Image8 img = tissueTexture(p, 128);
        double a = 0, b = 0;
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x) {
                const auto lab = labAt(img, x, y);
                a += lab[1] / (128 * 128);
                b += lab[2] / (128 * 128);
            }
        return std::array<double, 2>{std::hypot(a, b), std::atan2(b, a) * kDeg};
    };
    const auto grey = meanLch(toneColour(0)), salmon = meanLch(toneColour(0.5)), orange = meanLch(toneColour(1));
    EXPECT_LT(grey[1] + 10, salmon[1]);
    EXPECT_LT(salmon[1] + 10, orange[1]);
    EXPECT_LT(grey[0] + 8, salmon[0]);  // grey-pink is the least saturated
    EXPECT_NEAR(orange[1], 55, 6);
    EXPECT_NEAR(grey[1], 28, 6);
}

TEST(VesselNetwork, SegmentsFormConnectedTreesThatBranchByMurraysLawAndTaper) {
    const TissueParams p;
    const std::vector<VesselSegment> segs = vesselNetwork(p);
    ASSERT_GT(segs.size(), 500u);
    const auto ch = children(segs);
    int roots = 0, branchPoints = 0, trees = 0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
        const VesselSegment& s = segs[i];
        trees = std::max(trees, s.tree + 1);
        EXPECT_LE(s.r1, s.r0) << i;
        EXPECT_GT(s.depth, 0) << i;
        if (s.parent < 0) {
            ++roots;
            continue;
        }
        const VesselSegment& q = segs[static_cast<std::size_t>(s.parent)];
        ASSERT_LT(s.parent, static_cast<int>(i));
        EXPECT_EQ(s.tree, q.tree);
        // Connected: it starts where its parent ended.
        EXPECT_EQ(s.x0, q.x1);
        EXPECT_EQ(s.y0, q.y1);
        EXPECT_LE(s.r0, q.r1 * (1 + 1e-12)) << i;  // never wider than what feeds it
    }
    EXPECT_EQ(roots, trees);  // one root per tree
    for (std::size_t i = 0; i < segs.size(); ++i) {
        ASSERT_LE(ch[i].size(), 2u);
        if (ch[i].size() == 2) {
            ++branchPoints;
            const double r = segs[i].r1, a = segs[static_cast<std::size_t>(ch[i][0])].r0,
                         b = segs[static_cast<std::size_t>(ch[i][1])].r0;
            EXPECT_NEAR(r * r * r, a * a * a + b * b * b, 1e-9 * r * r * r) << i;
        }
    }
    EXPECT_GT(branchPoints, 3 * trees);  // a tree, not a bundle of lines
    // Tapering from root to tip: the thinnest segments are far thinner than the trunks.
    double rMax = 0, rMin = 1e9;
    for (const VesselSegment& s : segs) {
        rMax = std::max(rMax, s.r0);
        rMin = std::min(rMin, s.r1);
    }
    EXPECT_GT(rMax / rMin, 5);
}

TEST(VesselNetwork, CurvesSmoothlyWithoutRightAngles) {
    const std::vector<VesselSegment> segs = vesselNetwork(TissueParams{});
    const auto ch = children(segs);
    double worst = 0, branchWorst = 0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
        if (ch[i].size() == 1) worst = std::max(worst, angleBetween(segs[i], segs[static_cast<std::size_t>(ch[i][0])]));
        for (int c : ch[i])
            if (ch[i].size() == 2)
                branchWorst = std::max(branchWorst, angleBetween(segs[i], segs[static_cast<std::size_t>(c)]));
    }
    EXPECT_LT(worst, 25);        // along a vessel: no kinks (steps of <= 1 mm)
    EXPECT_LT(branchWorst, 90);  // branches leave at Murray's acute angles
}

TEST(VesselNetwork, MeandersButTendsAlongTheAirway) {
    // An isotropic walk's |cos| averages 2 / pi = 0.64; the default network
    // leans along the airway, yet meanders (well short of straight lines at 1).
    TissueParams p;
    const double tends = longitudinality(vesselNetwork(p));
    EXPECT_GT(tends, 0.68);
    EXPECT_LT(tends, 0.85);
    // The parameter is what does it.
    p.longitudinal = 0;
    EXPECT_LT(longitudinality(vesselNetwork(p)), tends - 0.03);
    p.longitudinal = 3;
    EXPECT_GT(longitudinality(vesselNetwork(p)), 0.85);
}

TEST(VesselTexture, VesselPixelsAreConnectedLongitudinalStructures) {
    constexpr int kSize = 256;
    TissueParams p;
    p.longitudinal = 3;  // the orientation check below needs a clear lean
    const auto A = vesselAbsorbance(p, kSize);
    // Vessel pixels: green absorbance above 0.05 (a 5 % darkening).
    std::vector<int> label(A.size(), -1);
    std::vector<std::size_t> sizes;
    std::size_t vesselPixels = 0;
    for (std::size_t i = 0; i < A.size(); ++i) {
        if (A[i][1] < 0.05 || label[i] >= 0) continue;
        const int id = static_cast<int>(sizes.size());
        std::size_t count = 0;
        std::vector<std::size_t> stack{i};
        label[i] = id;
        while (!stack.empty()) {  // 8-connected flood fill on the torus
            const std::size_t j = stack.back();
            stack.pop_back();
            ++count;
            const int x = static_cast<int>(j % kSize), y = static_cast<int>(j / kSize);
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const std::size_t k =
                        static_cast<std::size_t>(((y + dy + kSize) % kSize) * kSize + (x + dx + kSize) % kSize);
                    if (label[k] < 0 && A[k][1] >= 0.05) {
                        label[k] = id;
                        stack.push_back(k);
                    }
                }
        }
        sizes.push_back(count);
        vesselPixels += count;
    }
    ASSERT_GT(vesselPixels, A.size() / 50);  // vessels are there (> 2 % of the texture)
    std::sort(sizes.rbegin(), sizes.rend());
    // Connected: a few large structures hold most vessel pixels, not specks.
    const std::size_t top =
        std::accumulate(sizes.begin(), sizes.begin() + std::min<std::size_t>(20, sizes.size()), std::size_t{0});
    EXPECT_GT(static_cast<double>(top) / static_cast<double>(vesselPixels), 0.7) << sizes.size() << " components";
    // Longitudinal: the structure tensor of the absorbance image, summed, has
    // its dominant gradient across the vessels (along u), i.e. they run along v.
    double jxx = 0, jyy = 0, jxy = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            auto at = [&](int xx, int yy) {
                return A[static_cast<std::size_t>(((yy + kSize) % kSize) * kSize + (xx + kSize) % kSize)][1];
            };
            const double gx = 0.5 * (at(x + 1, y) - at(x - 1, y)), gy = 0.5 * (at(x, y + 1) - at(x, y - 1));
            jxx += gx * gx;
            jyy += gy * gy;
            jxy += gx * gy;
        }
    const double orientation = 0.5 * std::atan2(2 * jxy, jxx - jyy) * kDeg;  // dominant gradient, from u
    EXPECT_LT(std::abs(orientation), 15);
    EXPECT_GT(jxx, 2.5 * jyy);  // coherence: clearly anisotropic
}

TEST(VesselTexture, DeeperVesselsAreFainterWiderAndBluer) {
    constexpr int kSize = 256;
    struct Look {
        double peak, width, redShare;
    };
    auto look = [](double depth) {
        TissueParams p;
        p.vesselDepth = depth;
        p.hueVariation = p.chromaVariation = p.lightnessVariation = p.mottle = 0;
        const auto A = vesselAbsorbance(p, kSize);
        // Width ~ absorbance / its gradient: for a Gaussian stroke of sigma s,
        // integral |A'| / integral A = 2 / (s sqrt(2 pi)).
        double peak = 0, total = 0, grad = 0, red = 0;
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x) {
                const auto at = [&](int xx, int yy) {
                    return A[static_cast<std::size_t>(((yy + kSize) % kSize) * kSize + (xx + kSize) % kSize)];
                };
                const auto& a = at(x, y);
                peak = std::max(peak, a[1]);
                total += a[1];
                red += a[0];
                grad +=
                    std::hypot(0.5 * (at(x + 1, y)[1] - at(x - 1, y)[1]), 0.5 * (at(x, y + 1)[1] - at(x, y - 1)[1]));
            }
        return Look{peak, total / grad, red / total};
    };
    const Look shallow = look(0.08), deep = look(0.8);
    EXPECT_GT(shallow.peak, 1.5 * deep.peak);          // lower contrast (Beer-Lambert loss with depth)
    EXPECT_GT(deep.width, 1.5 * shallow.width);        // wider blur
    EXPECT_GT(deep.redShare, 1.5 * shallow.redShare);  // what is left to absorb is red: bluer
}

TEST(TissueTexture, BadParametersAreInputErrors) {
    TissueParams p;
    p.vesselContrast = 1.5;
    EXPECT_THROW(tissueTexture(p, 64), InputError);
    p = {};
    p.tileMm = 0;
    EXPECT_THROW(vesselNetwork(p), InputError);
    p = {};
    p.hueVariation = -1;
    try {
        tissueTexture(p, 64);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "tissue hue_variation");
    }
}

TEST(Appearance, DrawsStayInsideTheStatedRangesAndCoverThem) {
    const AppearanceRanges& R = kAppearanceRanges;
    auto inside = [](double v, const AppearanceRange& r) { return v >= r.lo && v <= r.hi; };
    double toneMin = 1, toneMax = 0, evMin = 1, evMax = -1, mucusMin = 1, mucusMax = 0, noiseMin = 9, noiseMax = 0;
    for (std::uint64_t seed = 1; seed <= 3000; ++seed) {
        const Appearance a = drawAppearance(seed);
        ASSERT_TRUE(inside(a.tone, R.tone)) << seed;
        ASSERT_TRUE(inside(a.tissue.hueVariation, R.hueVariation)) << seed;
        ASSERT_TRUE(inside(a.tissue.vesselDensity, R.vesselDensity)) << seed;
        ASSERT_TRUE(inside(a.tissue.vesselDepth, R.vesselDepth)) << seed;
        ASSERT_TRUE(inside(a.tissue.vesselContrast, R.vesselContrast)) << seed;
        ASSERT_TRUE(inside(a.mucus, R.mucus)) << seed;
        ASSERT_TRUE(inside(a.exposureEv, R.exposureEv)) << seed;
        ASSERT_TRUE(inside(a.softness, R.softness)) << seed;
        ASSERT_TRUE(inside(a.noise, R.noise)) << seed;
        ASSERT_TRUE(inside(a.flare, R.flare)) << seed;
        noiseMin = std::min(noiseMin, a.noise);
        noiseMax = std::max(noiseMax, a.noise);
        ASSERT_GE(a.tissue.hue, 28);
        ASSERT_LE(a.tissue.hue, 55);
        toneMin = std::min(toneMin, a.tone);
        toneMax = std::max(toneMax, a.tone);
        evMin = std::min(evMin, a.exposureEv);
        evMax = std::max(evMax, a.exposureEv);
        mucusMin = std::min(mucusMin, a.mucus);
        mucusMax = std::max(mucusMax, a.mucus);
    }
    EXPECT_LT(toneMin, 0.1);
    EXPECT_GT(toneMax, 0.9);
    EXPECT_LT(evMin, R.exposureEv.lo + 0.05);
    EXPECT_GT(evMax, R.exposureEv.hi - 0.05);
    EXPECT_LT(mucusMin, 0.02);
    EXPECT_GT(mucusMax, 0.98);
    EXPECT_LT(noiseMin, R.noise.lo * 1.02);
    EXPECT_GT(noiseMax, R.noise.hi * 0.98);
}

TEST(Appearance, DeterministicPerSeedAndZeroIsTheDefaultLook) {
    const Appearance a = drawAppearance(42), b = drawAppearance(42), c = drawAppearance(43);
    EXPECT_EQ(a.tone, b.tone);
    EXPECT_EQ(a.tissue.seed, b.tissue.seed);
    EXPECT_EQ(a.exposureEv, b.exposureEv);
    EXPECT_NE(a.tissue.seed, c.tissue.seed);
    EXPECT_NE(a.mucus, c.mucus);
    const Appearance d = drawAppearance(0);
    EXPECT_EQ(d.tone, 0.5);
    EXPECT_EQ(d.mucus, 0.3);
    EXPECT_EQ(d.exposureEv, 0);
    EXPECT_EQ(d.softness, 1);
    EXPECT_EQ(d.noise, 1);
    EXPECT_EQ(d.flare, 1);
    EXPECT_EQ(tissueTexture(d.tissue, 64), tissueTexture(64));
    EXPECT_DOUBLE_EQ(mucusOpacityScale(d.mucus), 1);
    EXPECT_DOUBLE_EQ(specularScale(d.mucus), 1);
    EXPECT_LT(specularScale(0), specularScale(1));
}

TEST(SceneVariation, KeySetsTheAppearanceAndTheMucusButKeepsTheFilesOwnMaterial) {
    const scene::Scene plain = scene::parseScene(R"({"mesh": "tube"})", "s.json");
    EXPECT_EQ(plain.variation, 0u);
    const scene::Scene v = scene::parseScene(R"({"mesh": "tube", "variation": 7})", "s.json");
    EXPECT_EQ(v.variation, 7u);
    const Appearance want = drawAppearance(7);
    EXPECT_EQ(v.appearance.tissue.seed, want.tissue.seed);
    EXPECT_EQ(v.appearance.exposureEv, want.exposureEv);
    using shading::Param;
    EXPECT_FLOAT_EQ(v.params[Param::MucusOpacity],
                    static_cast<float>(plain.params[Param::MucusOpacity] * mucusOpacityScale(want.mucus)));
    EXPECT_FLOAT_EQ(v.params[Param::SpecularStrength],
                    static_cast<float>(plain.params[Param::SpecularStrength] * specularScale(want.mucus)));
    // The scope: softness, noise (read noise x n, full well / n^2) and glare.
    EXPECT_FLOAT_EQ(v.params[Param::Softness], static_cast<float>(plain.params[Param::Softness] * want.softness));
    EXPECT_FLOAT_EQ(v.params[Param::ReadNoise], static_cast<float>(plain.params[Param::ReadNoise] * want.noise));
    EXPECT_FLOAT_EQ(v.params[Param::FullWell],
                    static_cast<float>(plain.params[Param::FullWell] / (want.noise * want.noise)));
    EXPECT_FLOAT_EQ(v.params[Param::Flare], static_cast<float>(plain.params[Param::Flare] * want.flare));
    // A camera value the file sets stays as set.
    const scene::Scene sharp =
        scene::parseScene(R"({"mesh": "tube", "variation": 7, "camera": {"softness_px": 0.5}})", "s.json");
    EXPECT_FLOAT_EQ(sharp.params[Param::Softness], 0.5f);
    EXPECT_FLOAT_EQ(sharp.params[Param::Flare], v.params[Param::Flare]);
    // The file's own mucus_opacity stays; the specular strength still follows the mucus.
    const scene::Scene own =
        scene::parseScene(R"({"mesh": "tube", "variation": 7, "material": {"mucus_opacity": 0.5}})", "s.json");
    EXPECT_FLOAT_EQ(own.params[Param::MucusOpacity], 0.5f);
    EXPECT_FLOAT_EQ(own.params[Param::SpecularStrength], v.params[Param::SpecularStrength]);
    // Another seed applied later replaces the first (no compounding); 0 restores the default.
    scene::Scene again = v;
    scene::applyVariation(again, 0);
    EXPECT_EQ(again.params, plain.params);
    EXPECT_EQ(again.appearance.tissue.seed, plain.appearance.tissue.seed);
    // The generated texture is the patient's.
    scene::Scene gen = scene::parseScene(R"({"mesh": "tube", "diffuse": "generated", "variation": 7})", "s.json");
    const scene::SceneAssets assets = scene::loadAssets(gen, 2, false);
    EXPECT_EQ(assets.diffuse, tissueTexture(want.tissue, assets.diffuse.width()));
}

TEST(SceneVariation, BadValuesAreOneLineErrorsNamingTheKey) {
    for (const char* bad : {R"(-1)", R"(2.5)", R"("7")", R"(true)"}) {
        try {
            scene::parseScene(std::string(R"({"mesh": "tube", "variation": )") + bad + "}", "s.json");
            ADD_FAILURE() << bad;
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), "variation") << bad;
            EXPECT_EQ(e.file(), "s.json");
            EXPECT_NE(e.reason().find("whole number"), std::string::npos) << e.what();
            EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
        }
    }
}

TEST(SceneVariation, CommandLineOptionRejectsBadSeedsInOneLine) {
    test::TempDir dir;
    for (const char* bad : {"-3", "abc", "1.5", "7x"}) {
        const test::RunResult r = test::runCli(std::string("render -o x.png --variation ") + bad, dir.path());
        EXPECT_NE(r.exitCode, 0) << bad;
        EXPECT_EQ(r.err.rfind("error: --variation", 0), 0u) << bad << ": " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_NE(r.err.find("whole number"), std::string::npos) << r.err;
    }
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(SceneVariation, CommandLineOptionDrawsThePatientAndReportsIt) {
    test::TempDir dir;
    { std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "variation": 3})"; }
    // --variation overrides the scene's key; the note names the patient drawn.
    const test::RunResult r =
        test::runCli("render tube.json -o x.png --size 32x32 --reference --variation 7", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string all = r.out + r.err;
    EXPECT_NE(all.find("variation 7: tissue hue"), std::string::npos) << all;
    EXPECT_EQ(all.find("variation 3:"), std::string::npos) << all;
    EXPECT_TRUE(std::filesystem::exists(dir / "x.png"));
}

TEST(SceneVariation, AResumedRenderMustUseTheSameVariation) {
    test::TempDir dir;
    { std::ofstream(dir / "tube.json") << R"({"mesh": "tube"})"; }
    const std::string base = "render tube.json -o f.png --size 24x24 --reference --frames 2";
    ASSERT_EQ(test::runCli(base + " --variation 3", dir.path()).exitCode, 0);
    const test::RunResult other = test::runCli(base + " --variation 4", dir.path());
    EXPECT_NE(other.exitCode, 0);
    EXPECT_NE(other.err.find("variation"), std::string::npos) << other.err;
    EXPECT_EQ(test::runCli(base + " --variation 3", dir.path()).exitCode, 0) << "the same seed resumes";
    // The default (no --variation) writes no key, so records from before the key existed still match.
    test::TempDir plain;
    { std::ofstream(plain / "tube.json") << R"({"mesh": "tube"})"; }
    ASSERT_EQ(test::runCli(base, plain.path()).exitCode, 0);
    EXPECT_EQ(test::readBytes(plain / "f.render.json").find("variation"), std::string::npos);
}

TEST(SceneVariation, BaseColourIsWhiteOverTheGeneratedTextureOnly) {
    using shading::Param;
    const std::array<float, 3> white{1, 1, 1}, registry = shading::ParamSet().color(Param::BaseColor);
    // The generated texture carries the tissue colour: no second tint.
    EXPECT_EQ(scene::defaultScene().params.color(Param::BaseColor), white);
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube"})", "s.json").params.color(Param::BaseColor), white);
    // A texture file, or none: the registry's tissue colour, as before.
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube", "diffuse": "t.png"})", "s.json").params.color(Param::BaseColor),
              registry);
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube", "diffuse": "none"})", "s.json").params.color(Param::BaseColor),
              registry);
    // The file's own value wins either way.
    const std::array<float, 3> own{0.5f, 0.4f, 0.3f};
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube", "diffuse": "none", "material": {"base_color": [0.5, 0.4, 0.3]}})",
                                "s.json")
                  .params.color(Param::BaseColor),
              own);
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube", "material": {"base_color": [0.5, 0.4, 0.3]}})", "s.json")
                  .params.color(Param::BaseColor),
              own);
}
