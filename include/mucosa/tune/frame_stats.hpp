#pragma once
// Every statistic the realism tool measures of a frame
// (../shared/realism/realism_stats.py, frame_stats), in C++: colour of the
// tissue, the highlights (highlight_stats.hpp), the illumination's profile
// and the texture. With them a rendered look is compared with a folder of a
// user's real frames, and a machine observer (observer.hpp) is trained on
// the same numbers the tool's observer.py reads.
//
// Pixel classes, on the 320 x 320 frame inside the disk of radius 152 px:
//   - highlight: HSV V > 0.92 and S < 0.25;
//   - tissue: not within 2 px of a highlight (4-connected dilation), L* >= 15;
//   - dark lumen: L* < 10.
// CIELAB from sRGB (D65), in single precision as the tool computes it.
#include <array>
#include <filesystem>
#include <string_view>
#include <vector>

#include <mucosa/image/image.hpp>
#include <mucosa/tune/highlight_stats.hpp>

namespace mucosa::tune {

// The tool's statistics in its order (its STATS keys); the ten ring means at
// the end are measured but not scored.
enum class FrameStat {
    LMean,
    LStd,
    AMean,
    AStd,
    BMean,
    BStd,
    ChromaMean,
    HueMean,
    HueStd,
    Colourfulness,
    HlFrac,
    HlCount,
    HlAreaMed,
    HlAreaP90,
    HlElongMed,
    HlRadius,
    HlLargest,
    HlClipFrac,
    DarkFrac,
    LAllMean,
    RingRatio,
    BandInner,
    BandMid,
    BandOuter,
    PsdSlope,
    PsdHfFrac,
    Lc16Med,
    Lc16P90,
    LapVar,
    NoiseSigma,
    Ring0,
    Ring1,
    Ring2,
    Ring3,
    Ring4,
    Ring5,
    Ring6,
    Ring7,
    Ring8,
    Ring9,
};
inline constexpr int kFrameStatCount = 40;
inline constexpr int kScoredStatCount = 30;  // the first 30; the rings are not scored

enum class StatGroup { Colour, Highlight, Illumination, Texture };

struct FrameStatInfo {
    std::string_view name;  // "L_mean", ... (the tool's key)
    StatGroup group;
    bool scored;               // counted in the distance and read by the observer
    std::string_view meaning;  // a few words for tables
};
const FrameStatInfo& info(FrameStat s) noexcept;
std::string_view groupName(StatGroup g) noexcept;  // "colour", "highlight", "illumination", "texture"
// false if `name` is not one of the keys.
bool findFrameStat(std::string_view name, FrameStat& out) noexcept;

// One frame's statistics; NaN where the tool writes null (too few tissue
// pixels for colour, no highlight component, no tile of tissue, ...; all of
// them with fewer than 1000 valid pixels).
struct FrameStats {
    std::array<double, kFrameStatCount> values{};
    double operator[](FrameStat s) const noexcept { return values[static_cast<std::size_t>(s)]; }
    double& operator[](FrameStat s) noexcept { return values[static_cast<std::size_t>(s)]; }
};

// The statistics of an RGB (RGBA: alpha ignored; grey: replicated) frame of
// any size, centre-cropped and resized as measureHighlights does; `mask`
// (optional, first channel > 127 = valid) is intersected with the disk.
FrameStats measureFrame(const image::Image8& frame, const image::Image8* mask = nullptr);
// A PNG frame, with <stem>.mask.png beside it as its mask if present.
FrameStats measureFrameStatsFile(const std::filesystem::path& png);

// Median and IQR per statistic over frames (NaN left out).
struct FrameStatsSummary {
    std::array<StatSummary, kFrameStatCount> stats{};
    int frames = 0;
    const StatSummary& operator[](FrameStat s) const noexcept { return stats[static_cast<std::size_t>(s)]; }
};
FrameStatsSummary summarise(const std::vector<FrameStats>& frames);

// The realism tool's overall score: the mean over the scored statistics the
// target has of statDistance (|median - target median| / target IQR, floored
// and capped as the tool does), with each statistic's distance (NaN where
// left out) and the mean per group.
struct RealismScore {
    double overall = 0;
    int terms = 0;
    std::array<double, kFrameStatCount> perStat{};
    std::array<double, 4> perGroup{};  // StatGroup order; NaN for a group with no term
};
RealismScore realismScore(const FrameStatsSummary& ours, const FrameStatsSummary& target);

// A set of frames: a statistics JSON written by the realism tool's `export`
// ({"frames": [{"name": ..., "stats": {...}}]}, null = no value; a missing
// key = no value) or a folder of PNG frames (sorted by name; <stem>.mask.png
// masks a frame). Throws InputError naming the file as readTargetFrames does.
std::vector<FrameStats> readFrameStats(const std::filesystem::path& path);

}  // namespace mucosa::tune
