#include <mucosa/tune/highlight_stats.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/tune/frame_stats.hpp>

namespace mucosa::tune {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct StatText {
    std::string_view name, meaning;
};
// In HighlightStat order; the names are realism_stats.py's STATS keys.
constexpr std::array<StatText, kHighlightStatCount> kStats = {{
    {"hl_frac", "fraction of the view that is highlight"},
    {"hl_count", "highlight components (>= 2 px) per frame"},
    {"hl_area_med", "median component area (px at 320)"},
    {"hl_area_p90", "90th percentile component area (px at 320)"},
    {"hl_elong_med", "median elongation, major/minor axis (>= 5 px)"},
    {"hl_radius", "mean normalised radius of highlight px"},
    {"hl_largest", "largest component / view area"},
    {"hl_clip_frac", "fraction of highlight px clipped (min RGB >= 250)"},
}};

// Thresholds of realism_stats.py: HL_V, HL_S; clipped at 250/255.
constexpr float kHighlightV = 0.92f, kHighlightS = 0.25f;
constexpr int kClipped = 250;
constexpr int kMinValid = 1000;  // fewer valid pixels: no statistics

// Area resampling of one axis (OpenCV INTER_AREA, Pillow BOX): destination
// sample i averages the source interval [i s, (i + 1) s), s = n / m, each
// source sample weighted by its overlap. Returns, per destination sample,
// (first source index, weights).
struct Tap {
    int first = 0;
    std::vector<double> w;
};
std::vector<Tap> areaTaps(int n, int m) {
    std::vector<Tap> taps(static_cast<std::size_t>(m));
    const double s = static_cast<double>(n) / m;
    for (int i = 0; i < m; ++i) {
        const double a = i * s, b = (i + 1) * s;
        Tap& t = taps[static_cast<std::size_t>(i)];
        t.first = static_cast<int>(std::floor(a));
        for (int k = t.first; k < n && k < b; ++k) {
            const double w = (std::min<double>(k + 1, b) - std::max<double>(k, a)) / s;
            if (w > 1e-12)
                t.w.push_back(w);
            else if (t.w.empty())
                ++t.first;
        }
    }
    return taps;
}

// Bilinear resampling of one axis with pixel centres at i + 0.5 (OpenCV
// INTER_LINEAR, Pillow BILINEAR when enlarging), edges clamped.
std::vector<Tap> linearTaps(int n, int m) {
    std::vector<Tap> taps(static_cast<std::size_t>(m));
    const double s = static_cast<double>(n) / m;
    for (int i = 0; i < m; ++i) {
        const double x = std::clamp((i + 0.5) * s - 0.5, 0.0, static_cast<double>(n - 1));
        const int x0 = std::min(static_cast<int>(std::floor(x)), n - 1);
        const double f = x - x0;
        Tap& t = taps[static_cast<std::size_t>(i)];
        t.first = x0;
        t.w = {1.0 - f};
        if (x0 + 1 < n) t.w.push_back(f);
    }
    return taps;
}

std::uint8_t round8(double v) {
    // Half up, as both OpenCV's fast area path and Pillow's fixed point round.
    return static_cast<std::uint8_t>(std::clamp(std::floor(v + 0.5), 0.0, 255.0));
}

image::Image8 toRgb(const image::Image8& in) {
    if (in.channels() == 3) return in;
    image::Image8 out(in.width(), in.height(), 3);
    for (int y = 0; y < in.height(); ++y)
        for (int x = 0; x < in.width(); ++x)
            for (int c = 0; c < 3; ++c) out.at(x, y, c) = in.at(x, y, in.channels() >= 3 ? c : 0);
    return out;
}

}  // namespace

std::string_view statName(HighlightStat s) noexcept {
    return kStats[static_cast<std::size_t>(s)].name;
}

std::string_view statMeaning(HighlightStat s) noexcept {
    return kStats[static_cast<std::size_t>(s)].meaning;
}

bool findStat(std::string_view name, HighlightStat& out) noexcept {
    for (int i = 0; i < kHighlightStatCount; ++i)
        if (kStats[static_cast<std::size_t>(i)].name == name) {
            out = static_cast<HighlightStat>(i);
            return true;
        }
    return false;
}

image::Image8 squareResize(const image::Image8& frame, int size) {
    MUCOSA_CHECK(!frame.empty() && size > 0, "squareResize needs a frame");
    // center_square(): the centred s x s block, s = min(w, h), offsets floored.
    const int s = std::min(frame.width(), frame.height());
    const int x0 = (frame.width() - s) / 2, y0 = (frame.height() - s) / 2;
    const int ch = frame.channels();
    if (s == size && frame.width() == s && frame.height() == s) return frame;
    const std::vector<Tap> taps = s > size ? areaTaps(s, size) : linearTaps(s, size);
    // Separable: rows first into doubles, then columns; one rounding at the end.
    std::vector<double> rows(static_cast<std::size_t>(s) * size * ch, 0.0);
    for (int y = 0; y < s; ++y)
        for (int i = 0; i < size; ++i) {
            const Tap& t = taps[static_cast<std::size_t>(i)];
            for (int c = 0; c < ch; ++c) {
                double acc = 0;
                for (std::size_t k = 0; k < t.w.size(); ++k)
                    acc += t.w[k] * frame.at(x0 + t.first + static_cast<int>(k), y0 + y, c);
                rows[(static_cast<std::size_t>(y) * size + i) * ch + c] = acc;
            }
        }
    image::Image8 out(size, size, ch);
    for (int j = 0; j < size; ++j) {
        const Tap& t = taps[static_cast<std::size_t>(j)];
        for (int i = 0; i < size; ++i)
            for (int c = 0; c < ch; ++c) {
                double acc = 0;
                for (std::size_t k = 0; k < t.w.size(); ++k)
                    acc += t.w[k] * rows[((static_cast<std::size_t>(t.first) + k) * size + i) * ch + c];
                out.at(i, j, c) = round8(acc);
            }
    }
    return out;
}

FrameHighlights measureHighlights(const image::Image8& frame, const image::Image8* mask) {
    if (frame.empty()) throw InputError("frame", "", "is empty");
    const image::Image8 rgb = toRgb(squareResize(frame, kStatsSize));
    image::Image8 m;
    if (mask != nullptr && !mask->empty()) m = squareResize(*mask, kStatsSize);
    constexpr int N = kStatsSize;
    const double c = (N - 1) / 2.0;
    std::vector<std::uint8_t> valid(static_cast<std::size_t>(N) * N), hl(valid.size());
    std::vector<double> radius(valid.size());
    int nvalid = 0;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * N + x;
            radius[i] = std::hypot(y - c, x - c) / kStatsRadius;
            valid[i] = radius[i] < 1.0 && (m.empty() || m.at(x, y, 0) > 127);
            nvalid += valid[i];
            // HSV as realism_stats.py computes it, in float32: V = max, S = (max - min) / max.
            const float r = rgb.at(x, y, 0) / 255.0f, g = rgb.at(x, y, 1) / 255.0f, b = rgb.at(x, y, 2) / 255.0f;
            const float mx = std::max({r, g, b}), mn = std::min({r, g, b});
            const float sat = mx > 0 ? (mx - mn) / std::max(mx, 1e-6f) : 0.0f;
            hl[i] = valid[i] && mx > kHighlightV && sat < kHighlightS;
        }
    FrameHighlights out;
    out.values.fill(kNaN);
    if (nvalid < kMinValid) return out;
    long hlCount = 0;
    for (std::uint8_t h : hl) hlCount += h;
    out[HighlightStat::Fraction] = static_cast<double>(hlCount) / nvalid;

    // 8-connected components (scipy.ndimage.label with a 3 x 3 structure), by
    // flood fill; per component the pixel count and the sums for its second moments.
    struct Component {
        long n = 0;
        double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    };
    std::vector<Component> comps;
    std::vector<int> label(hl.size(), -1);
    std::vector<int> stack;
    for (int y0 = 0; y0 < N; ++y0)
        for (int x0 = 0; x0 < N; ++x0) {
            const std::size_t i0 = static_cast<std::size_t>(y0) * N + x0;
            if (!hl[i0] || label[i0] >= 0) continue;
            const int id = static_cast<int>(comps.size());
            Component k;
            label[i0] = id;
            stack.assign(1, static_cast<int>(i0));
            while (!stack.empty()) {
                const int p = stack.back();
                stack.pop_back();
                const int px = p % N, py = p / N;
                ++k.n;
                k.sx += px;
                k.sy += py;
                k.sxx += static_cast<double>(px) * px;
                k.syy += static_cast<double>(py) * py;
                k.sxy += static_cast<double>(px) * py;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int qx = px + dx, qy = py + dy;
                        if (qx < 0 || qy < 0 || qx >= N || qy >= N) continue;
                        const std::size_t q = static_cast<std::size_t>(qy) * N + qx;
                        if (hl[q] && label[q] < 0) {
                            label[q] = id;
                            stack.push_back(static_cast<int>(q));
                        }
                    }
            }
            comps.push_back(k);
        }
    std::vector<double> areas, elongations;
    for (const Component& k : comps) {
        if (k.n < 2) continue;
        areas.push_back(static_cast<double>(k.n));
        if (k.n < 5) continue;
        // np.cov (unbiased) of the pixel coordinates plus 1/12 on the diagonal
        // (the variance of a unit pixel), major/minor axis = sqrt(l1 / l0).
        const double n = static_cast<double>(k.n);
        const double cxx = (k.sxx - k.sx * k.sx / n) / (n - 1) + 1.0 / 12.0;
        const double cyy = (k.syy - k.sy * k.sy / n) / (n - 1) + 1.0 / 12.0;
        const double cxy = (k.sxy - k.sx * k.sy / n) / (n - 1);
        const double mean = 0.5 * (cxx + cyy), d = std::hypot(0.5 * (cxx - cyy), cxy);
        elongations.push_back(std::sqrt((mean + d) / std::max(mean - d, 1e-9)));
    }
    out[HighlightStat::Count] = static_cast<double>(areas.size());
    if (areas.empty()) {
        out[HighlightStat::Largest] = 0.0;
        return out;
    }
    out[HighlightStat::AreaMedian] = percentile(areas, 50);
    out[HighlightStat::AreaP90] = percentile(areas, 90);
    out[HighlightStat::Largest] = *std::max_element(areas.begin(), areas.end()) / nvalid;
    if (!elongations.empty()) out[HighlightStat::Elongation] = percentile(elongations, 50);
    double rsum = 0;
    long clipped = 0;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * N + x;
            if (!hl[i]) continue;
            rsum += radius[i];
            clipped += std::min({rgb.at(x, y, 0), rgb.at(x, y, 1), rgb.at(x, y, 2)}) >= kClipped;
        }
    out[HighlightStat::Radius] = rsum / static_cast<double>(hlCount);
    out[HighlightStat::Clipped] = static_cast<double>(clipped) / static_cast<double>(hlCount);
    return out;
}

double percentile(std::vector<double> v, double q) {
    std::erase_if(v, [](double x) { return std::isnan(x); });
    if (v.empty()) return kNaN;
    std::sort(v.begin(), v.end());
    // numpy's default ('linear'): position q/100 (n - 1), interpolated.
    const double pos = q / 100.0 * static_cast<double>(v.size() - 1);
    const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    const double f = pos - static_cast<double>(lo);
    return v[lo] + (v[hi] - v[lo]) * f;
}

HighlightSummary summarise(const std::vector<FrameHighlights>& frames) {
    HighlightSummary s;
    s.frames = static_cast<int>(frames.size());
    for (int k = 0; k < kHighlightStatCount; ++k) {
        std::vector<double> v;
        for (const FrameHighlights& f : frames)
            if (!std::isnan(f.values[static_cast<std::size_t>(k)])) v.push_back(f.values[static_cast<std::size_t>(k)]);
        StatSummary& st = s.stats[static_cast<std::size_t>(k)];
        st.n = static_cast<int>(v.size());
        st.median = percentile(v, 50);
        st.q1 = percentile(v, 25);
        st.q3 = percentile(v, 75);
    }
    return s;
}

double statDistance(const StatSummary& ours, const StatSummary& target) {
    if (target.n == 0) return kNaN;
    if (ours.n == 0) return kDistanceCap;
    const double den = std::max({target.iqr(), 0.05 * std::abs(target.median), 1e-3});
    return std::min(std::abs(ours.median - target.median) / den, kDistanceCap);
}

Distance distance(const HighlightSummary& ours, const HighlightSummary& target,
                  const std::vector<HighlightStat>& stats) {
    Distance d;
    d.perStat.fill(kNaN);
    for (HighlightStat s : stats) {
        const double v = statDistance(ours[s], target[s]);
        d.perStat[static_cast<std::size_t>(s)] = v;
        if (std::isnan(v)) continue;
        d.total += v;
        ++d.terms;
    }
    return d;
}

namespace {

std::string lower(std::string s) {
    for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

}  // namespace

std::vector<fs::path> listFrames(const fs::path& folder) {
    std::vector<fs::path> frames;
    int other = 0;
    for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
        if (!e.is_regular_file()) continue;
        const std::string name = lower(e.path().filename().string());
        if (name.ends_with(".mask.png")) continue;
        if (name.ends_with(".png"))
            frames.push_back(e.path());
        else if (name.ends_with(".jpg") || name.ends_with(".jpeg") || name.ends_with(".bmp") ||
                 name.ends_with(".tif") || name.ends_with(".tiff"))
            ++other;
    }
    if (frames.empty())
        throw InputError(
            "frames", folder.string(),
            other > 0 ? "has no PNG frames (only PNG is read: convert the JPEG/BMP/TIFF frames)" : "has no PNG frames");
    std::sort(frames.begin(), frames.end());
    return frames;
}

FrameFile readFrameFile(const fs::path& png) {
    FrameFile f;
    f.frame = image::to8(image::readPng(png));
    fs::path maskPath = png;
    maskPath.replace_extension(".mask.png");
    std::error_code ec;
    if (fs::exists(maskPath, ec)) f.mask = image::to8(image::readPng(maskPath));
    return f;
}

FrameHighlights measureFrameFile(const fs::path& png) {
    const FrameFile f = readFrameFile(png);
    return measureHighlights(f.frame, f.mask.empty() ? nullptr : &f.mask);
}

std::vector<FrameHighlights> readTargetFrames(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw IoError("target", path.string(), "no such file or folder");
    std::vector<FrameHighlights> out;
    if (!fs::is_directory(path, ec)) {
        // A statistics file: its highlight statistics (read with the others).
        for (const FrameStats& f : readFrameStats(path)) {
            FrameHighlights h;
            for (int k = 0; k < kHighlightStatCount; ++k)
                h.values[static_cast<std::size_t>(k)] =
                    f.values[static_cast<std::size_t>(FrameStat::HlFrac) + static_cast<std::size_t>(k)];
            out.push_back(h);
        }
        return out;
    }
    for (const fs::path& p : listFrames(path)) out.push_back(measureFrameFile(p));
    return out;
}

}  // namespace mucosa::tune
