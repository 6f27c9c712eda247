#pragma once
// `mucosa fit`: patient-specific texture and shading from registered frames.
//  1. back-project every frame onto the mesh through a depth pass, collecting
//     per pixel gamma = cos(V, N), the distance z to the viewpoint and the
//     linear intensity (backproject.cpp);
//  2. fit the seven parameters of rho(gamma) * delta(r) jointly with a per-texel
//     albedo, with a robust (Cauchy) loss so that specular highlights and
//     disocclusions are outliers (Ceres; solve.cpp);
//  3. divide the shading out, blend frames weighted by gamma and distance, fill
//     unseen texels by push-pull inpainting (texture.cpp).
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/brdf.hpp>

namespace mucosa::fit {

// One observation of a surface point.
struct Sample {
    float u = 0, v = 0;        // texture coordinates (OpenGL convention)
    float gamma = 0, z = 0;    // cos(V, N) and distance to the viewpoint (mm)
    float footprint = 0;       // area the pixel covers on the surface (mm^2); 0: unknown
    std::array<float, 3> I{};  // linear intensity, 0..1
    std::uint32_t frame = 0;
};

struct BackprojectStats {
    std::size_t pixels = 0, hits = 0, backFacing = 0, saturated = 0, outsideView = 0, grazing = 0, samples = 0;
};

using Progress = std::function<void(const std::string& stage, double fraction)>;

enum class Solver {
    Schur,  // specialised Levenberg-Marquardt with Schur elimination (default, fast)
    Ceres,  // Ceres Solver, DENSE_SCHUR: the general-purpose reference
};

struct FitOptions {
    Solver solver = Solver::Schur;
    int textureSize = 1024;     // output atlas: about textureSize^2 texels, shaped to the UV rectangle
    int holdout = 0;            // frames held out for validation (evenly spaced)
    bool robust = true;         // Cauchy loss; off: plain least squares
    double cauchyScale = 0.02;  // residual scale of the loss, linear intensity
    double minGamma = 0.1;      // grazing views are dropped
    double saturation = 0.99;   // pixels at or above this (before linearising) are dropped
    bool monotoneDelta = true;  // delta(r) non-increasing and >= 0 on [0, 1], as a lamp's (off: free cubic)
    // zmax candidates, quantiles of the distances: the one whose fit explains
    // all samples best is kept (delta is flat beyond zmax, r = 1).
    std::vector<double> zmaxQuantiles{0.9, 0.95, 0.98, 0.995, 1.0};
    int fitGrid = 128;                     // albedo grid of the joint solve (coarser than the atlas)
    std::size_t maxSolveSamples = 150000;  // samples the joint solve uses at most (random subset)
    std::size_t minSamples = 2000;         // fewer usable samples is an error
    int threads = 0;
    std::uint64_t seed = 1;
    Progress progress;  // optional
};

struct HoldoutResult {
    std::size_t frame = 0;
    std::string image;
    double psnr = 0;  // dB over compared pixels
    std::size_t compared = 0, masked = 0;
};

// Where a fitted delta(r) rises most: delta(to) - delta(from), from < to.
struct DeltaRise {
    double amount = 0;  // 0: non-increasing on [0, 1]
    double from = 0, to = 0;
    double deltaFrom = 1, deltaTo = 1;
};

// The free cubic and, when it rose, the constrained refit.
struct FalloffCheck {
    std::array<double, 3> freeD{0, 0, 0};  // d1..d3 of the free fit
    DeltaRise rise;                        // of the free fit
    bool constrained = false;              // the result is the non-increasing refit
    double riseSampleFraction = 0;         // solve samples with r in [rise.from, rise.to]
    double freeCost = 0, constrainedCost = 0;
};

struct FitResult {
    shading::BrdfParams brdf;
    image::ImageF texture;                          // 3 channels, linear albedo; first row = top (v = 1)
    image::ImageF coverage;                         // 1 channel, blend weight per texel (0 = filled by inpainting)
    std::array<float, 2> uvMin{0, 0}, uvMax{1, 1};  // the atlas spans this UV rectangle
    // Atlas width and height (0: textureSize square) and the texel's side on
    // the surface (mm; 0: unknown), set by fitFrames from the mesh.
    std::array<int, 2> atlasSize{0, 0};
    double texelMm = 0;
    double coveredFraction = 0;
    // The factor moved from the albedo into rho so that the texture fits in
    // [0, 1] (1: none; see fitFrames): rho(1) = albedoScale.
    double albedoScale = 1;
    std::vector<BackprojectStats> perFrame;
    std::vector<HoldoutResult> holdout;
    std::size_t solveSamples = 0, solveTexels = 0;
    std::array<double, 2> zObserved{0, 0};  // 1st and 99th percentile of sample distances (mm)
    int solverIterations = 0;
    // Robust cost at the solution: sum over the solve's samples of
    // c^2 log(1 + e^2 / c^2), e the RGB residual norm (sum e^2 with robust off).
    double solveCost = 0;
    double solveSeconds = 0, totalSeconds = 0;
    // Binned data for the report: mean shading-normalised intensity per bin.
    std::vector<std::array<double, 3>> rhoBins, deltaBins;  // (x, mean, count)
    FalloffCheck falloff;
    std::vector<std::string> warnings;  // for the user: one line each, with the evidence
};

// rho(gamma) delta(r) with r clamped to [0, 1], as the renderer evaluates it
// (common_shading.glsl, depthRatio): beyond the fitted range of distances the
// fall-off is held at its end value, never extrapolated.
double fittedShading(const shading::BrdfParams& brdf, double gamma, double z) noexcept;

// Back-projects one frame (image already decoded and linearised, 3 channels).
// `mask` (optional, 1 channel, from loadFrameImage): pixels not to use.
std::vector<Sample> backproject(const mesh::Mesh& mesh, const frames::Frame& frame, const image::ImageF& linear,
                                const image::Image8* mask, const FitOptions& options, std::uint32_t frameIndex,
                                BackprojectStats* stats);

// Reads, checks and linearises a frame's image (8/16-bit grey or RGB PNG).
// `mask`, if given, says per pixel what may not be used: kMaskSaturated (a
// channel at or above `saturation`) or kMaskOutsideView (outside the scope's
// field of view, see outsideFieldOfView, widened by kViewMarginPx).
constexpr std::uint8_t kMaskSaturated = 1, kMaskOutsideView = 2;
constexpr int kViewMarginPx = 2;
image::ImageF loadFrameImage(const frames::Frame& frame, const frames::Response& response,
                             image::Image8* mask = nullptr, double saturation = 0.99);

// The pixels outside the scope's field of view: black (every channel 0)
// and connected to the image border, so that a dark lumen inside the
// circle or octagon is not taken for it. 1 = outside. Widened by
// `marginPx` (a real scope's mask edge is soft).
std::vector<std::uint8_t> outsideFieldOfView(const image::ImageF& image, int marginPx = 0);

// The joint robust solve on samples (zmin/zmax from the data).
shading::BrdfParams solveBrdf(const std::vector<Sample>& samples, const FitOptions& options,
                              FitResult* diagnostics = nullptr);

// The atlas for a UV rectangle: about N^2 texels, the sides in a power-of-two
// ratio that makes texels square on the surface (within a factor sqrt(2)),
// from the mesh's millimetres per unit of u and of v (area-weighted medians
// over its triangles). A long airway's centerline UVs span 1 turn around and
// 3-4 along: a square atlas there had texels 3x longer along the tube.
struct AtlasShape {
    int width = 0, height = 0;
    double texelMm = 0;  // sqrt of the texel's area on the surface
};
AtlasShape atlasShape(const mesh::Mesh& mesh, std::array<float, 2> uvMin, std::array<float, 2> uvMax, int N);

// Albedo atlas from samples and fitted shading; push-pull fills the rest.
void buildTexture(const std::vector<Sample>& samples, const shading::BrdfParams& brdf, const FitOptions& options,
                  FitResult& result);

// Push-pull inpainting (Gortler et al. 1996, "The Lumigraph", pull-push):
// texels with weight 0 take the weighted average of coarser levels.
void pushPull(image::ImageF& color, const image::ImageF& weight, int threads = 0);

// Everything: checks, back-projection, solve, texture, hold-out validation.
FitResult fitFrames(const mesh::Mesh& mesh, const frames::FrameSet& frames, const FitOptions& options);

// Writes OUTDIR/brdf.json, texture.png, coverage.png, report.html, rho.svg,
// delta.svg, report.json (all atomically; the directory is created).
void writeFitOutputs(const FitResult& result, const std::filesystem::path& dir);

// Renders what the fitted model predicts for a frame (texture x rho x delta),
// linear, 3 channels; pixels that see nothing are 0 and flagged in `seen`.
image::ImageF renderPrediction(const mesh::Mesh& mesh, const frames::Frame& frame, const shading::BrdfParams& brdf,
                               const image::ImageF& texture, std::array<float, 2> uvMin, std::array<float, 2> uvMax,
                               std::vector<std::uint8_t>* seen = nullptr, int threads = 0);

}  // namespace mucosa::fit
