#pragma once
// Specular highlight statistics of a frame, defined exactly as the realism
// tool measures them (../shared/realism/realism_stats.py, frame_stats): so a
// rendered frame, a folder of real frames and a statistics file exported by
// that tool are compared on the same numbers.
//   - the frame is centre-cropped to a square and resized to 320 x 320 (area
//     averaging when shrinking, bilinear when enlarging, as OpenCV's
//     INTER_AREA / INTER_LINEAR), 8 bits per channel;
//   - only pixels inside the disk of radius 0.95 * 160 = 152 px about the
//     centre (and inside an optional mask) count;
//   - highlight = HSV value V > 0.92 and saturation S < 0.25 (white glints on
//     pink tissue), in single precision as the tool computes them;
//   - highlights are grouped into 8-connected components; components of
//     >= 2 px are counted.
#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <mucosa/image/image.hpp>

namespace mucosa::tune {

inline constexpr int kStatsSize = 320;         // frames are measured at 320 x 320
inline constexpr double kStatsRadius = 152.0;  // analysis disk radius, px (0.95 * 320 / 2)

// The highlight statistics, in the tool's order; the names are its keys.
enum class HighlightStat {
    Fraction,    // hl_frac: fraction of the valid disk that is highlight
    Count,       // hl_count: components of >= 2 px
    AreaMedian,  // hl_area_med: median component area (px at 320)
    AreaP90,     // hl_area_p90: 90th percentile of component area (linear interpolation)
    Elongation,  // hl_elong_med: median major/minor axis ratio of components of >= 5 px
    Radius,      // hl_radius: mean normalised radius (0 centre, 1 disk edge) of highlight px
    Largest,     // hl_largest: largest component / valid disk area
    Clipped,     // hl_clip_frac: fraction of highlight px with min(R, G, B) >= 250
};
inline constexpr int kHighlightStatCount = 8;

std::string_view statName(HighlightStat s) noexcept;     // "hl_frac", ...
std::string_view statMeaning(HighlightStat s) noexcept;  // a few words for tables and plots
// nullptr-free lookup: false if `name` is not one of the keys.
bool findStat(std::string_view name, HighlightStat& out) noexcept;

// One frame's statistics; NaN where the tool writes null (no component of
// >= 2 px: every statistic but hl_frac, hl_count and hl_largest; no component
// of >= 5 px: hl_elong_med; fewer than 1000 valid pixels: all of them).
struct FrameHighlights {
    std::array<double, kHighlightStatCount> values{};
    double operator[](HighlightStat s) const noexcept { return values[static_cast<std::size_t>(s)]; }
    double& operator[](HighlightStat s) noexcept { return values[static_cast<std::size_t>(s)]; }
};

// Centre square crop, then resize to size x size (area averaging down,
// bilinear up), 8 bits, the channels kept. A frame already size x size is
// returned unchanged.
image::Image8 squareResize(const image::Image8& frame, int size = kStatsSize);

// The statistics of an RGB (or RGBA: alpha ignored; grey: replicated) frame of
// any size. `mask` (optional, any size, one or more channels; first channel
// > 127 = valid) is cropped and resized the same way and intersected with the
// disk.
FrameHighlights measureHighlights(const image::Image8& frame, const image::Image8* mask = nullptr);

// Median and interquartile range of one statistic over frames, NaN values
// left out (numpy.percentile, linear interpolation); n = 0 when every frame
// is NaN (median and IQR then NaN).
struct StatSummary {
    double median = 0, q1 = 0, q3 = 0;
    int n = 0;
    double iqr() const noexcept { return q3 - q1; }
};
struct HighlightSummary {
    std::array<StatSummary, kHighlightStatCount> stats{};
    int frames = 0;
    const StatSummary& operator[](HighlightStat s) const noexcept { return stats[static_cast<std::size_t>(s)]; }
};
HighlightSummary summarise(const std::vector<FrameHighlights>& frames);

// numpy.percentile(values, q) with linear interpolation (q in 0..100); values
// need not be sorted; NaN for none.
double percentile(std::vector<double> values, double q);

// The realism tool's distance of one statistic (distance() in
// realism_stats.py): |median - target median| / max(target IQR, 0.05 |target
// median|, 1e-3), capped at 10; 10 when `ours` has no value; NaN when the
// target has none (the statistic is then left out).
inline constexpr double kDistanceCap = 10.0;
double statDistance(const StatSummary& ours, const StatSummary& target);

// Sum of statDistance over `stats` (those the target has), and how many were summed.
struct Distance {
    double total = 0;
    int terms = 0;
    std::array<double, kHighlightStatCount> perStat{};  // NaN where left out
};
Distance distance(const HighlightSummary& ours, const HighlightSummary& target,
                  const std::vector<HighlightStat>& stats);

// The PNG frames of a folder, sorted by name, without the masks (<stem>.mask.png).
// InputError when there are none.
std::vector<std::filesystem::path> listFrames(const std::filesystem::path& folder);
// A PNG frame and <stem>.mask.png beside it (empty if there is none).
struct FrameFile {
    image::Image8 frame, mask;
};
FrameFile readFrameFile(const std::filesystem::path& png);
// One frame file measured, with <stem>.mask.png beside it as its mask if present.
FrameHighlights measureFrameFile(const std::filesystem::path& png);

// A target set of frames: a statistics JSON written by the realism tool's
// `export` ({"frames": [{"name": ..., "stats": {"hl_frac": ..., ...}}]}, null
// = no value; other keys are ignored) or a folder of PNG frames (sorted by
// name; <stem>.mask.png beside a frame masks it and is not a frame).
// Throws InputError naming the file: missing, malformed, no frames, a
// highlight statistic that is not a number or null.
std::vector<FrameHighlights> readTargetFrames(const std::filesystem::path& path);

}  // namespace mucosa::tune
