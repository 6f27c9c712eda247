#include <mucosa/reflectance/tissue_texture.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/noise/fractal.hpp>

namespace mucosa::reflectance {

namespace {

constexpr double kPi = std::numbers::pi;

// A small deterministic generator (splitmix64, Steele et al. 2014): one
// sequence per seed whatever the standard library (<random>'s distributions
// are implementation-defined).
struct Rng {
    std::uint64_t state;
    std::uint64_t next() noexcept {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() noexcept { return static_cast<double>(next() >> 11) * 0x1p-53; }  // [0, 1)
    double uniform(double lo, double hi) noexcept { return lo + (hi - lo) * uniform(); }
    // Box-Muller (1958).
    double normal() noexcept {
        const double u1 = 1.0 - uniform(), u2 = uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
    }
};

// ---- Vessel growth ---------------------------------------------------------
// A vessel is a random walk with smooth curvature: the curvature kappa is an
// Ornstein-Uhlenbeck process (correlation length kCurvatureCorrMm, stationary
// standard deviation kCurvatureStd), so the direction never jumps; a drift
// -lambda sin(2 theta) / 2 turns it towards the airway axis (theta = 0 or pi,
// theta measured from +v), as the longitudinal vessels of the tracheal and
// bronchial mucosa run. Branch points come at exponentially distributed
// intervals whose mean is proportional to the radius; the flow splits in a
// share f : 1 - f, Murray's law (Murray 1926) gives the radii
// r1 = r f^(1/3), r2 = r (1 - f)^(1/3) (so r^3 = r1^3 + r2^3), and the
// minimum-volume branch angles (Murray 1926; Zamir 1978)
// cos theta1 = (r^4 + r1^4 - r2^4) / (2 r^2 r1^2). Between branch points the
// radius tapers slowly (kTaperMm). The thinner branch rises towards the
// surface, so the deep trunks feed fine superficial twigs (the mucosa's
// capillary plexus lies under the epithelium, the larger vessels deeper in
// the lamina propria and submucosa).
// Growth steps follow the vessel's drawn width (3 x its blur sigma, below):
// fine vessels take short steps so their curvature stays smooth at texel
// scale, wide blurred ones long steps (their curvature is blurred anyway),
// which keeps drawing cost proportional to length rather than area.
constexpr double kMinStepMm = 0.25, kMaxStepMm = 1.0, kMaxTurnRad = 0.25;
// Width of the scattering blur per mm of depth (see "Vessel rendering").
constexpr double kBlurPerDepth = 0.6;
constexpr double kCurvatureCorrMm = 2.5;
constexpr double kCurvatureStd = 0.22;     // rad/mm
constexpr double kLongitudinalRate = 0.6;  // 1/mm at longitudinal = 1
constexpr double kTaperMm = 80.0;
constexpr double kBranchPerRadius = 45.0;  // mean mm between branch points / radius in mm
constexpr double kLifePerRadius = 90.0;    // mean length of a side branch (mm) / its radius in mm
constexpr double kMinRadiusMm = 0.025;
constexpr double kMinDepthMm = 0.03;
// Vessels do not start or stop in the open: a trunk rises from the
// submucosa over the first 30 % of its length and every vessel dives back
// over its last 30 % (kDiveMm deeper), so they fade in and out.
constexpr double kDiveMm = 0.7;
constexpr double kTreesPerTile = 14.0;
// The plexus: short trees (8-20 % of a tile), a third of the trunks' radius
// and depth.
constexpr double kPlexusTreesPerTile = 80.0, kPlexusRadius = 0.35, kPlexusDepth = 0.5;
constexpr int kMaxSegmentsPerTree = 5000;

struct Tip {
    double x, y, theta, kappa, r, depth, path, start, maxPath, nextBranch;
    bool trunk;
    int parent;
};

double smoothstep(double a, double b, double x) {
    const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

double murrayAngle(double r0, double r1, double r2) {
    const double c = (std::pow(r0, 4) + std::pow(r1, 4) - std::pow(r2, 4)) / (2 * r0 * r0 * r1 * r1);
    return std::acos(std::clamp(c, -1.0, 1.0));
}

constexpr std::array<TissueParamInfo, 14> kTissueRegistry = {{
    {"tile_mm", &TissueParams::tileMm, 1, 1000, "mm", "tissue spanned by the texture along u and v", true},
    {"lightness", &TissueParams::lightness, 0, 100, "L*", "mean mucosa lightness L* (CIELAB)", false},
    {"chroma", &TissueParams::chroma, 0, 100, "", "mean mucosa chroma C*ab", false},
    {"hue", &TissueParams::hue, 0, 360, "deg", "mean mucosa hue angle h_ab", false},
    {"hue_variation", &TissueParams::hueVariation, 0, 45, "deg", "spread of hue over 10-20 mm patches", false},
    {"chroma_variation", &TissueParams::chromaVariation, 0, 50, "", "spread of chroma over the patches", false},
    {"lightness_variation", &TissueParams::lightnessVariation, 0, 50, "L*", "spread of lightness over the patches",
     false},
    {"mottle", &TissueParams::mottle, 0, 30, "L*", "spread of the 1-2 mm mottle", false},
    {"stipple", &TissueParams::stipple, 0, 30, "L*", "spread of the 0.2-0.4 mm stipple of glands and folds", false},
    {"vessel_density", &TissueParams::vesselDensity, 0, 8, "", "vessel trees per tile, x the default", true},
    {"trunk_radius", &TissueParams::trunkRadius, 0.01, 2, "mm", "mean radius of the vessel trunks", true},
    {"vessel_depth", &TissueParams::vesselDepth, 0.01, 3, "mm", "mean depth of the trunks under the surface", true},
    {"vessel_contrast", &TissueParams::vesselContrast, 0, 1, "", "light a vessel at the surface absorbs", false},
    {"longitudinal", &TissueParams::longitudinal, 0, 10, "", "how strongly vessels run along the airway", false},
}};

void validate(const TissueParams& p) {
    auto need = [](bool ok, const char* name, double v, const char* why) {
        if (!ok || !std::isfinite(v))
            throw InputError(fmt::format("tissue {}", name), "", fmt::format("{} {}", v, why));
    };
    need(p.tileMm > 0, "tile_mm", p.tileMm, "must be positive");
    need(p.lightness >= 0 && p.lightness <= 100, "lightness", p.lightness, "must be in 0..100");
    need(p.chroma >= 0 && p.chroma <= 100, "chroma", p.chroma, "must be in 0..100");
    need(std::isfinite(p.hue), "hue", p.hue, "must be finite");
    need(p.hueVariation >= 0 && p.hueVariation <= 45, "hue_variation", p.hueVariation, "must be in 0..45 deg");
    need(p.chromaVariation >= 0, "chroma_variation", p.chromaVariation, "must not be negative");
    need(p.lightnessVariation >= 0, "lightness_variation", p.lightnessVariation, "must not be negative");
    need(p.mottle >= 0, "mottle", p.mottle, "must not be negative");
    need(p.stipple >= 0, "stipple", p.stipple, "must not be negative");
    need(p.vesselDensity >= 0 && p.vesselDensity <= 8, "vessel_density", p.vesselDensity, "must be in 0..8");
    need(p.trunkRadius > 0 && p.trunkRadius <= 2, "trunk_radius", p.trunkRadius, "must be in (0, 2] mm");
    need(p.vesselDepth > 0 && p.vesselDepth <= 3, "vessel_depth", p.vesselDepth, "must be in (0, 3] mm");
    need(p.vesselContrast >= 0 && p.vesselContrast <= 1, "vessel_contrast", p.vesselContrast, "must be in 0..1");
    need(p.longitudinal >= 0 && p.longitudinal <= 10, "longitudinal", p.longitudinal, "must be in 0..10");
}

// Two populations: trunks (TissueParams::trunkRadius and vesselDepth, most
// of a tile long) and a finer, shallower plexus of short trees between them.
struct TreeKind {
    double radius, depth, minLength, maxLength;  // mm; lengths as fractions of the tile
};

void growTree(const TissueParams& p, const TreeKind& kind, Rng& rng, int tree, double rootX,
              std::vector<VesselSegment>& out) {
    const double lambda = kLongitudinalRate * p.longitudinal;
    // OU curvature: kappa' = kappa (1 - ds / l) + sigma sqrt(ds) N, whose
    // stationary variance is sigma^2 l / 2.
    const double sigmaK = kCurvatureStd * std::sqrt(2.0 / kCurvatureCorrMm);
    std::vector<Tip> tips;
    Tip root{};
    root.x = rootX;
    root.y = rng.uniform(0, p.tileMm);
    root.theta = (rng.uniform() < 0.5 ? 0.0 : kPi) + 0.35 * rng.normal();
    root.kappa = kCurvatureStd * rng.normal();
    root.r = kind.radius * std::clamp(std::exp(0.3 * rng.normal()), 0.5, 2.0);
    root.depth = std::max(kMinDepthMm, kind.depth * std::clamp(std::exp(0.35 * rng.normal()), 0.4, 2.5));
    root.nextBranch = -std::log(1.0 - rng.uniform()) * kBranchPerRadius * root.r;
    root.parent = -1;
    root.trunk = true;
    root.maxPath = p.tileMm * rng.uniform(kind.minLength, kind.maxLength);  // less than a tile
    tips.push_back(root);
    int segments = 0;
    while (!tips.empty()) {
        Tip t = tips.back();
        tips.pop_back();
        while (t.r >= kMinRadiusMm && t.path < t.maxPath && segments < kMaxSegmentsPerTree) {
            const double blur = std::sqrt(t.r * t.r / 3 + kBlurPerDepth * kBlurPerDepth * t.depth * t.depth);
            double ds = std::clamp(3 * blur, kMinStepMm, kMaxStepMm);
            t.kappa += -t.kappa * ds / kCurvatureCorrMm + sigmaK * std::sqrt(ds) * rng.normal();
            // ... and short enough that one step turns by at most kMaxTurnRad.
            ds = std::max(kMinStepMm, std::min(ds, kMaxTurnRad / std::max(std::abs(t.kappa), 1e-9)));
            t.theta += (t.kappa - lambda * 0.5 * std::sin(2 * t.theta)) * ds;
            VesselSegment s{};
            s.x0 = t.x;
            s.y0 = t.y;
            t.x += ds * std::sin(t.theta);
            t.y += ds * std::cos(t.theta);
            s.x1 = t.x;
            s.y1 = t.y;
            s.r0 = t.r;
            t.r *= std::exp(-ds / kTaperMm);
            s.r1 = t.r;
            const double u = (t.path - t.start) / (t.maxPath - t.start);
            s.depth = t.depth + kDiveMm * (smoothstep(0.7, 1.0, u) + (t.trunk ? 1 - smoothstep(0.0, 0.3, u) : 0.0));
            s.tree = tree;
            s.parent = t.parent;
            t.parent = static_cast<int>(out.size());
            out.push_back(s);
            ++segments;
            t.path += ds;
            t.nextBranch -= ds;
            if (t.nextBranch > 0) continue;
            // Bifurcation: Murray radii and angles, the minor branch on a random side.
            const double f = rng.uniform(0.55, 0.85);
            const double r1 = t.r * std::cbrt(f), r2 = t.r * std::cbrt(1 - f);
            if (r2 < kMinRadiusMm) {  // a side branch too fine to draw: none, and no split
                t.nextBranch = -std::log(1.0 - rng.uniform()) * kBranchPerRadius * t.r;
                continue;
            }
            const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
            const double jitter = 1.0 + 0.15 * rng.normal();
            Tip minor = t;
            minor.r = r2;
            minor.theta = t.theta - side * murrayAngle(t.r, r2, r1) * jitter;
            minor.kappa = -side * kCurvatureStd * std::abs(rng.normal());
            minor.depth = std::max(kMinDepthMm, t.depth * std::pow(r2 / t.r, 1.2));
            minor.trunk = false;
            minor.start = t.path;
            minor.maxPath = std::min(t.maxPath, t.path + kLifePerRadius * r2 * rng.uniform(0.5, 1.5));
            minor.nextBranch = -std::log(1.0 - rng.uniform()) * kBranchPerRadius * r2;
            t.theta += side * murrayAngle(t.r, r1, r2) * jitter;
            t.r = r1;
            t.nextBranch = -std::log(1.0 - rng.uniform()) * kBranchPerRadius * r1;
            tips.push_back(minor);
        }
    }
}

// ---- Colour ----------------------------------------------------------------
// CIE 15:2004 L*a*b* with the D65 white; IEC 61966-2-1 sRGB primaries and
// transfer curve.
constexpr double kXn = 0.95047, kYn = 1.0, kZn = 1.08883;
constexpr double kDelta = 6.0 / 29.0;

double labFinv(double t) {
    return t > kDelta ? t * t * t : 3 * kDelta * kDelta * (t - 4.0 / 29.0);
}
double labF(double t) {
    return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.0 / 29.0;
}
std::array<double, 3> labToLinear(double L, double a, double b) {
    const double fy = (L + 16) / 116, fx = fy + a / 500, fz = fy - b / 200;
    const double X = kXn * labFinv(fx), Y = kYn * labFinv(fy), Z = kZn * labFinv(fz);
    return {3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z, -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z,
            0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z};
}
double encodeSrgb(double v) {
    v = std::clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
}
double decodeSrgb(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Linear -> 8-bit sRGB code by the decoded midpoints between codes: exact
// rounding of the encoded value without a pow per pixel.
struct SrgbEncoder {
    std::array<float, 255> edges;
    SrgbEncoder() {
        for (int k = 0; k < 255; ++k)
            edges[static_cast<std::size_t>(k)] = static_cast<float>(decodeSrgb((k + 0.5) / 255));
    }
    std::uint8_t operator()(float v) const {
        return static_cast<std::uint8_t>(std::upper_bound(edges.begin(), edges.end(), v) - edges.begin());
    }
};

// A tileable fractal field, standardised to zero mean and unit variance so
// the TissueParams variations are standard deviations. Evaluated on a grid
// of `res` texels (at most `size`; enough for its highest octave, 4 texels
// per cycle) and upsampled bilinearly with wrap-around: the low-frequency
// fields cost a sixteenth of a full-size fill.
std::vector<float> field(int size, int res, double frequency, int octaves, std::uint64_t seed, double z) {
    res = std::min(res, size);
    noise::FractalParams f;
    f.frequency = frequency;
    f.octaves = std::max(1, std::min(octaves, noise::resolvableOctaves(f, res)));
    f.seed = seed;
    f.z = z;
    f.tileable = true;
    const std::size_t rn = static_cast<std::size_t>(res) * static_cast<std::size_t>(res);
    std::vector<float> v(rn);
    noise::fillFractal(f, std::span<float>(v), res, res);
    double sum = 0, sum2 = 0;
    for (float x : v) {
        sum += x;
        sum2 += static_cast<double>(x) * x;
    }
    const double mean = sum / static_cast<double>(rn);
    const double sd = std::sqrt(std::max(1e-12, sum2 / static_cast<double>(rn) - mean * mean));
    for (float& x : v) x = static_cast<float>((x - mean) / sd);
    if (res == size) return v;
    std::vector<float> out(static_cast<std::size_t>(size) * static_cast<std::size_t>(size));
    const float scale = static_cast<float>(res) / static_cast<float>(size);
    for (int y = 0; y < size; ++y) {
        const float fy = static_cast<float>(y) * scale;
        const int y0 = static_cast<int>(fy), y1 = (y0 + 1) % res;
        const float ty = fy - static_cast<float>(y0);
        const float* r0 = &v[static_cast<std::size_t>(y0) * res];
        const float* r1 = &v[static_cast<std::size_t>(y1) * res];
        float* o = &out[static_cast<std::size_t>(y) * size];
        for (int x = 0; x < size; ++x) {
            const float fx = static_cast<float>(x) * scale;
            const int x0 = static_cast<int>(fx), x1 = (x0 + 1) % res;
            const float tx = fx - static_cast<float>(x0);
            const float top = r0[x0] + tx * (r0[x1] - r0[x0]), bottom = r1[x0] + tx * (r1[x1] - r1[x0]);
            o[x] = top + ty * (bottom - top);
        }
    }
    return out;
}

// ---- Vessel rendering --------------------------------------------------------
// Light reaches a vessel at depth d through the scattering mucosa and comes
// back: per channel c the share of the remitted light that visited depth d
// falls as exp(-d / delta_c) (Beer-Lambert-like, with the effective
// penetration depths of light in mucosa: red reaches deepest), and the image
// of the vessel is blurred by a point-spread function whose width grows in
// proportion to the depth (diffusion theory: a buried absorber's shadow
// spreads over ~ its depth; Kienle et al. 1996, "Why do veins appear blue?",
// Appl. Opt. 35(7)). So shallow vessels are sharp and red-purple (blood
// absorbs green and blue, Hb/HbO2 spectra, Prahl 1999), deep ones wide, faint
// and bluish: what they remove is mostly red, the only light that got there.
//
// A vessel of radius r absorbs across its width a total
// W_c = integral (1 - exp(-mu_c 2 sqrt(r^2 - x^2))) dx
//     ~ 2 r (1 - exp(-mu_c pi r / 2))
// (exact in both limits: 2 r opaque, mu_c pi r^2 thin); that absorbed width
// is spread as a Gaussian of variance (r^2 / 3: the opaque chord) + (beta
// d)^2 (the scattering blur) + (0.5 texel)^2 (the pixel footprint, so thin
// vessels are anti-aliased and keep their integral instead of aliasing),
// clipped at 1, and scaled by contrast x exp(-d / delta_c).
constexpr std::array<double, 3> kMuBloodPerMm = {1.4, 30.0, 13.0};  // effective, blood, sRGB R G B bands
constexpr std::array<double, 3> kPenetrationMm = {1.6, 0.55, 0.32};
constexpr double kPixelSigma = 0.5;
constexpr double kCutoffSigmas = 3.5;

struct Stroke {
    float sigma;  // px
    float w[3];   // peak of the spread absorbed width, before clipping
};

Stroke stroke(double r, double depth, double pxPerMm) {
    const double sigmaMm2 = r * r / 3 + (kBlurPerDepth * depth) * (kBlurPerDepth * depth);
    const double sigma = std::sqrt(sigmaMm2 * pxPerMm * pxPerMm + kPixelSigma * kPixelSigma);
    Stroke s{};
    s.sigma = static_cast<float>(sigma);
    for (std::size_t c = 0; c < 3; ++c) {
        const double W = 2 * r * (1 - std::exp(-kMuBloodPerMm[c] * kPi * r / 2)) * pxPerMm;
        s.w[c] = static_cast<float>(W / (sigma * std::sqrt(2 * kPi)));
    }
    return s;
}

// Draws every tree into `transmission` (linear, per pixel and channel): per
// tree the largest absorbed share (so a vessel's overlapping segments and its
// branch points do not double), trees multiplied (Beer-Lambert: absorbers in
// series).
void drawVessels(const TissueParams& p, const std::vector<VesselSegment>& segs, int size,
                 std::vector<float>& transmission) {
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    transmission.assign(3 * n, 1.0f);
    std::vector<float> tree(3 * n, 0.0f);
    std::vector<std::uint32_t> touched;
    const double pxPerMm = size / p.tileMm;
    const float contrast = static_cast<float>(p.vesselContrast);
    auto flush = [&] {
        for (std::uint32_t i : touched) {
            for (std::size_t c = 0; c < 3; ++c) {
                transmission[3 * i + c] *= 1.0f - tree[3 * i + c];
                tree[3 * i + c] = 0;
            }
        }
        touched.clear();
    };
    int current = segs.empty() ? 0 : segs.front().tree;
    for (const VesselSegment& s : segs) {
        if (s.tree != current) {
            flush();
            current = s.tree;
        }
        const Stroke a = stroke(s.r0, s.depth, pxPerMm), b = stroke(s.r1, s.depth, pxPerMm);
        float k[3];  // contrast x the share of remitted light that reached the vessel's depth
        for (std::size_t c = 0; c < 3; ++c)
            k[c] = contrast * static_cast<float>(std::exp(-s.depth / kPenetrationMm[c]));
        const float x0 = static_cast<float>(s.x0 * pxPerMm), y0 = static_cast<float>(s.y0 * pxPerMm);
        const float dx = static_cast<float>((s.x1 - s.x0) * pxPerMm), dy = static_cast<float>((s.y1 - s.y0) * pxPerMm);
        const float len2 = std::max(1e-12f, dx * dx + dy * dy);
        const float reach = static_cast<float>(kCutoffSigmas) * std::max(a.sigma, b.sigma);
        const int ix0 = static_cast<int>(std::floor(std::min(x0, x0 + dx) - reach));
        const int ix1 = static_cast<int>(std::ceil(std::max(x0, x0 + dx) + reach));
        const int iy0 = static_cast<int>(std::floor(std::min(y0, y0 + dy) - reach));
        const int iy1 = static_cast<int>(std::ceil(std::max(y0, y0 + dy) + reach));
        for (int iy = iy0; iy <= iy1; ++iy) {
            const int wy = ((iy % size) + size) % size;
            const float py = static_cast<float>(iy) + 0.5f - y0;
            for (int ix = ix0; ix <= ix1; ++ix) {
                const float px = static_cast<float>(ix) + 0.5f - x0;
                const float t = std::clamp((px * dx + py * dy) / len2, 0.0f, 1.0f);
                const float ex = px - t * dx, ey = py - t * dy;
                const float d2 = ex * ex + ey * ey;
                const float sigma = a.sigma + t * (b.sigma - a.sigma);
                if (d2 > kCutoffSigmas * kCutoffSigmas * sigma * sigma) continue;
                const float g = std::exp(-0.5f * d2 / (sigma * sigma));
                const int wx = ((ix % size) + size) % size;
                const std::uint32_t i =
                    static_cast<std::uint32_t>(wy) * static_cast<std::uint32_t>(size) + static_cast<std::uint32_t>(wx);
                float* T = &tree[3 * static_cast<std::size_t>(i)];
                if (T[0] == 0 && T[1] == 0 && T[2] == 0) touched.push_back(i);
                for (int c = 0; c < 3; ++c) {
                    const float w = a.w[c] + t * (b.w[c] - a.w[c]);
                    T[c] = std::max(T[c], std::max(k[c] * std::min(1.0f, w * g), 1e-30f));
                }
            }
        }
    }
    flush();
}

}  // namespace

std::array<double, 3> labToSrgb(const std::array<double, 3>& lab) noexcept {
    const auto lin = labToLinear(lab[0], lab[1], lab[2]);
    return {encodeSrgb(lin[0]), encodeSrgb(lin[1]), encodeSrgb(lin[2])};
}

std::array<double, 3> srgbToLab(const std::array<double, 3>& rgb) noexcept {
    const double r = decodeSrgb(rgb[0]), g = decodeSrgb(rgb[1]), b = decodeSrgb(rgb[2]);
    const double X = 0.4124564 * r + 0.3575761 * g + 0.1804375 * b;
    const double Y = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
    const double Z = 0.0193339 * r + 0.1191920 * g + 0.9503041 * b;
    const double fx = labF(X / kXn), fy = labF(Y / kYn), fz = labF(Z / kZn);
    return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

std::vector<VesselSegment> vesselNetwork(const TissueParams& p) {
    validate(p);
    Rng rng{p.seed ^ 0x5EEDF00DCAFEull};
    // Poisson-like count: the expected number, rounded stochastically.
    const int trees = static_cast<int>(std::floor(kTreesPerTile * p.vesselDensity + rng.uniform()));
    const int plexus = static_cast<int>(std::floor(kPlexusTreesPerTile * p.vesselDensity + rng.uniform()));
    const TreeKind trunk{p.trunkRadius, p.vesselDepth, 0.3, 0.6};
    const TreeKind fine{p.trunkRadius * kPlexusRadius, p.vesselDepth * kPlexusDepth, 0.05, 0.15};
    std::vector<VesselSegment> out;
    // Roots stratified around the airway (u), uniform along it: the
    // longitudinal vessels spread evenly around the wall instead of clumping.
    for (int t = 0; t < trees; ++t) growTree(p, trunk, rng, t, (t + rng.uniform()) * p.tileMm / trees, out);
    for (int t = 0; t < plexus; ++t) growTree(p, fine, rng, trees + t, (t + rng.uniform()) * p.tileMm / plexus, out);
    return out;
}

image::Image8 tissueTexture(const TissueParams& p, int size) {
    MUCOSA_CHECK(size >= 8, "texture size must be at least 8");
    validate(p);
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    Rng seeds{p.seed};
    // Low-frequency patches (3-4 cycles per tile: 15-20 mm at the trachea) and
    // the fine mottle (24-48 cycles: 1-2 mm grains).
    const std::vector<float> hyper = field(size, 64, 3, 3, seeds.next(), 0.37);
    const std::vector<float> hueF = field(size, 64, 4, 3, seeds.next(), 0.61);
    const std::vector<float> chromaF = field(size, 64, 3, 3, seeds.next(), 0.23);
    const std::vector<float> lightF = field(size, 64, 4, 3, seeds.next(), 0.79);
    const std::vector<float> fine = field(size, 512, 24, 3, seeds.next(), 0.53);
    const std::vector<float> grain = field(size, 512, 48, 2, seeds.next(), 0.17);
    const std::vector<float> stippleF = field(size, 1024, 128, 2, seeds.next(), 0.41);

    std::vector<float> T;
    drawVessels(p, vesselNetwork(p), size, T);

    const SrgbEncoder encode;
    image::Image8 img(size, size, 3);
    const double deg = kPi / 180;
    for (std::size_t i = 0; i < n; ++i) {
        // Hyperaemia (one shared field): redder, more saturated, darker.
        const double e = hyper[i];
        const double h = (p.hue + p.hueVariation * (-0.7 * e + 0.71 * hueF[i])) * deg;
        const double C =
            std::max(0.0, p.chroma + p.chromaVariation * (0.6 * e + 0.8 * chromaF[i]) + 0.35 * p.mottle * grain[i]);
        const double L = p.lightness + p.lightnessVariation * (-0.8 * e + 0.6 * lightF[i]) + p.mottle * fine[i] +
                         p.stipple * stippleF[i];
        const auto rgb = labToLinear(L, C * std::cos(h), C * std::sin(h));
        std::uint8_t* px = img.data() + 3 * i;
        for (std::size_t c = 0; c < 3; ++c) px[c] = encode(static_cast<float>(std::max(0.0, rgb[c])) * T[3 * i + c]);
    }
    return img;
}

std::span<const TissueParamInfo> tissueRegistry() noexcept {
    return kTissueRegistry;
}

const TissueParamInfo* findTissueParam(std::string_view name) noexcept {
    for (const TissueParamInfo& i : kTissueRegistry)
        if (i.name == name) return &i;
    return nullptr;
}

image::Image8 tissueTexture(int size, std::uint64_t seed) {
    TissueParams p;
    p.seed = seed;
    return tissueTexture(p, size);
}

}  // namespace mucosa::reflectance
