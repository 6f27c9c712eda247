#pragma once
// Patient-to-patient appearance: the tissue colour, the vessel network, the
// amount of mucus and the exposure vary between patients (and bronchoscopes'
// automatic gain), and the scope's softness, noise and glare between
// bronchoscopes and their video processors. drawAppearance(seed) draws one patient from the ranges of
// kAppearanceRanges (docs/theory.md, "Patient variation"); seed 0 is the
// default look.
#include <cstdint>

#include <mucosa/reflectance/tissue_texture.hpp>

namespace mucosa::reflectance {

struct Appearance {
    // The generated texture's parameters (its colour from `tone`).
    TissueParams tissue;
    // Mucosa colour along grey-pink (0) .. yellowish salmon (0.5, the
    // default) .. orange-yellow (1); toneColour maps it to CIELAB.
    double tone = 0.5;
    // Mucus on the wall, 0 (dry) .. 1 (copious); 0.3 is the registry's
    // default material (mucusOpacityScale and specularScale are 1 there).
    double mucus = 0.3;
    // Exposure offset in EV (stops) the camera applies on top of its own.
    double exposureEv = 0;
    // The bronchoscope and its video processor, as factors on the camera's
    // defaults: the optics' softness (camera.softness_px), the noise left
    // after the processor's noise reduction (camera.read_noise times it,
    // camera.full_well divided by its square: the shot noise's deviation
    // times it) and the veiling glare (camera.flare).
    double softness = 1;
    double noise = 1;
    double flare = 1;
};

struct AppearanceRange {
    double lo, hi;
};

// The ranges drawAppearance draws from (the table in docs/theory.md).
struct AppearanceRanges {
    AppearanceRange tone{0.0, 1.0};             // triangular, mode 0.5
    AppearanceRange hueVariation{4.0, 9.0};     // deg, uniform
    AppearanceRange vesselDensity{0.5, 1.8};    // x default, log-uniform
    AppearanceRange vesselDepth{0.18, 0.45};    // mm, uniform
    AppearanceRange vesselContrast{0.55, 0.9};  // uniform
    AppearanceRange mucus{0.0, 1.0};            // uniform
    AppearanceRange exposureEv{-0.7, 0.7};      // EV, uniform
    AppearanceRange softness{0.55, 1.2};        // x default, uniform (1.2: camera.softness_px at most)
    AppearanceRange noise{0.5, 2.0};            // x default, log-uniform
    AppearanceRange flare{0.3, 2.0};            // x default, log-uniform
};
inline constexpr AppearanceRanges kAppearanceRanges{};

// `p` with lightness, chroma and hue of the mucosa tone t in 0..1, linear
// between the anchors grey-pink (L* 63, C* 22, h 28 deg), yellowish salmon
// (64, 36, 41: the default TissueParams) and orange-yellow (66, 42, 55).
TissueParams toneColour(double tone, TissueParams p = {});

// The default look (seed 0): TissueParams{}, tone 0.5, mucus 0.3, 0 EV.
Appearance defaultAppearance();

// One patient, deterministic per seed (its own generator, the same on every
// platform); 0 = defaultAppearance(). The texture seed is drawn too, so every
// patient has their own vessel network.
Appearance drawAppearance(std::uint64_t seed);

// How the mucus amount scales the material: the mucous layer's opacity in
// proportion to the amount, the highlight strength from 0.6x (dry) rising
// linearly (a thicker, smoother wet film reflects more). Both 1 at the
// default amount.
double mucusOpacityScale(double mucus) noexcept;
double specularScale(double mucus) noexcept;

}  // namespace mucosa::reflectance
