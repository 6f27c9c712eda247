#pragma once
// The generated subject (diffuse) texture of airway mucosa: tissue colour that
// varies as real mucosa does, and a branching, tapering vessel network that
// fades with depth under the mucosa (docs/theory.md, "Tissue texture").
//
// The texture is tileable in both u (around the airway) and v (along it): the
// vessels are grown on a torus and every noise field is periodic. Its pixels
// are sRGB-encoded 8-bit albedo (IEC 61966-2-1): a renderer decodes them to
// linear reflectance before lighting. Image x runs along u, y along v (the
// airway axis; docs/theory.md, "Conventions", for which end is v = 0).
#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include <mucosa/image/image.hpp>

namespace mucosa::reflectance {

// Everything that shapes the texture. Lengths are in mm of tissue: the
// texture spans tileMm in u and v (centerline UVs repeat the map once per
// circumference of the widest tube, so the default is the phantom's trachea,
// pi x 18 mm). Colours are CIELAB (D65) of the albedo under white light.
struct TissueParams {
    std::uint64_t seed = 7;
    double tileMm = 56.5;

    // Mean mucosa colour: L*, chroma C*ab, hue angle h_ab (deg). The default
    // is the salmon pink of white-light bronchoscopy (h 41 deg, b* ~24: the
    // median real frame of ../shared/realism, under the default lamp and
    // camera, measures h ~37 deg).
    double lightness = 64;
    double chroma = 32;
    double hue = 41;
    // Standard deviations of the low-frequency patches (~10-20 mm across):
    // hue (deg), chroma and lightness (CIELAB units). Hyperaemic patches are
    // redder, more saturated and a little darker (one shared field).
    // Real mucosa is patchy within one view (hue spread ~6.5 deg in real
    // frames): redder hyperaemic areas beside paler, yellower ones. (The
    // phantom adds seamless patches of its own in its vertex tint; on the
    // texture, stronger patches show the UV atlas's seams.)
    double hueVariation = 6;
    double chromaVariation = 4;
    double lightnessVariation = 3;
    // Standard deviations, in L*, of the fine mottle (~1-2 mm grains) and of
    // the stipple of the mucosa's glands and folds (~0.2-0.4 mm).
    double mottle = 3.6;
    double stipple = 2.7;

    // Vessels: trees per tile at density 1 (x vesselDensity), the trunks'
    // mean radius (mm) and mean depth under the surface (mm), the share of
    // light a fully absorbing vessel at the surface removes (0..1), and how
    // strongly vessels turn to run along v (0 = isotropic random walk).
    double vesselDensity = 1;
    double trunkRadius = 0.22;
    double vesselDepth = 0.3;
    double vesselContrast = 0.75;
    double longitudinal = 0.3;
};

// The texture's parameters by name: the keys of a scene's "tissue" object
// and of `--set tissue.<key>` (docs/scene-format.md), with the range a scene
// may set (validate's, made finite) and what each does.
struct TissueParamInfo {
    std::string_view name;  // "lightness", "vessel_density", ...
    double TissueParams::*member;
    double min, max;
    std::string_view unit;  // "", "deg", "mm", "L*"
    std::string_view meaning;
    bool scales;  // a patient's draw scales it (lengths, density) rather than offsets it
};
std::span<const TissueParamInfo> tissueRegistry() noexcept;
const TissueParamInfo* findTissueParam(std::string_view name) noexcept;

// One straight piece of a vessel, in mm, unwrapped (the torus wraps x and y
// modulo tileMm when drawn). A vessel starts at its tree's root; each segment
// starts where its parent ended; a branch point is a segment with two
// children, whose start radii obey Murray's law r^3 = r1^3 + r2^3.
struct VesselSegment {
    double x0, y0, x1, y1;  // x along u (around), y along v (along the airway)
    double r0, r1;          // radius at the start and end (r1 <= r0)
    double depth;           // under the surface (mm)
    int tree;               // index of the tree it belongs to
    int parent;             // index of the segment it continues, -1 at a root
};

// The vessel network of `p` (deterministic per seed).
std::vector<VesselSegment> vesselNetwork(const TissueParams& p);

// The texture, RGB, size x size, sRGB-encoded albedo. Throws InputError
// naming the parameter if `p` is out of range (negative variations, contrast
// outside 0..1, non-positive lengths) and MUCOSA_CHECKs size >= 8.
image::Image8 tissueTexture(const TissueParams& p, int size);

// The default look with another seed.
image::Image8 tissueTexture(int size, std::uint64_t seed = 7);

// CIELAB (D65) <-> sRGB-encoded values in 0..1 (IEC 61966-2-1 matrix and
// transfer curve; CIE 15:2004 for L*a*b*). Out-of-gamut results are clamped.
std::array<double, 3> labToSrgb(const std::array<double, 3>& lab) noexcept;
std::array<double, 3> srgbToLab(const std::array<double, 3>& rgb) noexcept;

}  // namespace mucosa::reflectance
