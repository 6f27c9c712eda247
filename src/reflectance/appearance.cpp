#include <mucosa/reflectance/appearance.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace mucosa::reflectance {

namespace {

constexpr double kDefaultMucus = 0.3;

// splitmix64 (Steele et al. 2014): a fixed sequence per seed on every platform.
struct Rng {
    std::uint64_t state;
    double uniform() noexcept {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1p-53;  // [0, 1)
    }
    double uniform(const AppearanceRange& r) noexcept { return r.lo + (r.hi - r.lo) * uniform(); }
};

// Tone anchors (L*, C*ab, h_ab in deg): grey-pink, yellowish salmon, orange-yellow.
constexpr std::array<std::array<double, 3>, 3> kTones = {{{63, 20, 28}, {64, 32, 41}, {66, 38, 55}}};

}  // namespace

TissueParams toneColour(double tone, TissueParams p) {
    const double t = std::clamp(tone, 0.0, 1.0) * 2;
    const std::size_t i = t < 1 ? 0 : 1;
    const double f = t - static_cast<double>(i);
    p.lightness = kTones[i][0] + f * (kTones[i + 1][0] - kTones[i][0]);
    p.chroma = kTones[i][1] + f * (kTones[i + 1][1] - kTones[i][1]);
    p.hue = kTones[i][2] + f * (kTones[i + 1][2] - kTones[i][2]);
    return p;
}

Appearance defaultAppearance() {
    Appearance a;
    a.tissue = toneColour(a.tone);
    return a;
}

Appearance drawAppearance(std::uint64_t seed) {
    if (seed == 0) return defaultAppearance();
    const AppearanceRanges& R = kAppearanceRanges;
    Rng rng{seed * 0xD1B54A32D192ED03ull + 0x8CB92BA72F3D8DD7ull};
    Appearance a;
    // Triangular on the tone range (the sum of two uniforms): most patients
    // near the middle, the grey-pink and orange-yellow ends rarer.
    a.tone = R.tone.lo + (R.tone.hi - R.tone.lo) * 0.5 * (rng.uniform() + rng.uniform());
    a.tissue = toneColour(a.tone);
    a.tissue.seed = static_cast<std::uint64_t>(rng.uniform() * 0x1p53) + 1;
    a.tissue.hueVariation = rng.uniform(R.hueVariation);
    a.tissue.vesselDensity = std::exp(std::log(R.vesselDensity.lo) +
                                      (std::log(R.vesselDensity.hi) - std::log(R.vesselDensity.lo)) * rng.uniform());
    a.tissue.vesselDepth = rng.uniform(R.vesselDepth);
    a.tissue.vesselContrast = rng.uniform(R.vesselContrast);
    a.mucus = rng.uniform(R.mucus);
    a.exposureEv = rng.uniform(R.exposureEv);
    // Drawn last, so the draws above stay what they were for every seed.
    const auto logUniform = [&](const AppearanceRange& r) {
        return std::exp(std::log(r.lo) + (std::log(r.hi) - std::log(r.lo)) * rng.uniform());
    };
    a.softness = rng.uniform(R.softness);
    a.noise = logUniform(R.noise);
    a.flare = logUniform(R.flare);
    return a;
}

double mucusOpacityScale(double mucus) noexcept {
    return std::max(0.0, mucus) / kDefaultMucus;
}

double specularScale(double mucus) noexcept {
    return 0.6 + 0.4 * std::max(0.0, mucus) / kDefaultMucus;
}

}  // namespace mucosa::reflectance
