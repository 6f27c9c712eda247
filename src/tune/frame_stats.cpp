#include <mucosa/tune/frame_stats.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>

#include "core/json_parse.hpp"

namespace mucosa::tune {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int N = kStatsSize;

using G = StatGroup;
// In FrameStat order: realism_stats.py's STATS.
constexpr std::array<FrameStatInfo, kFrameStatCount> kInfo = {{
    {"L_mean", G::Colour, true, "tissue mean CIELAB L*"},
    {"L_std", G::Colour, true, "tissue spread of L*"},
    {"a_mean", G::Colour, true, "tissue mean a* (red-green)"},
    {"a_std", G::Colour, true, "tissue spread of a*"},
    {"b_mean", G::Colour, true, "tissue mean b* (yellow-blue)"},
    {"b_std", G::Colour, true, "tissue spread of b*"},
    {"chroma_mean", G::Colour, true, "tissue mean chroma C*ab"},
    {"hue_mean", G::Colour, true, "tissue circular mean hue h_ab (deg)"},
    {"hue_std", G::Colour, true, "tissue circular spread of hue (deg)"},
    {"colourfulness", G::Colour, true, "Hasler-Suesstrunk colourfulness of the tissue"},
    {"hl_frac", G::Highlight, true, "fraction of the view that is highlight"},
    {"hl_count", G::Highlight, true, "highlight components (>= 2 px) per frame"},
    {"hl_area_med", G::Highlight, true, "median highlight area (px at 320)"},
    {"hl_area_p90", G::Highlight, true, "90th percentile highlight area (px at 320)"},
    {"hl_elong_med", G::Highlight, true, "median highlight elongation (>= 5 px)"},
    {"hl_radius", G::Highlight, true, "mean normalised radius of highlight px"},
    {"hl_largest", G::Highlight, true, "largest highlight / view area"},
    {"hl_clip_frac", G::Highlight, true, "fraction of highlight px clipped"},
    {"dark_frac", G::Illumination, true, "dark-lumen fraction (L* < 10)"},
    {"L_all_mean", G::Illumination, true, "mean L* over the view"},
    {"ring_ratio", G::Illumination, true, "brightest ring / median ring"},
    {"band_inner", G::Illumination, true, "mean L* at r < 0.3"},
    {"band_mid", G::Illumination, true, "mean L* at 0.3 <= r < 0.7"},
    {"band_outer", G::Illumination, true, "mean L* at r >= 0.7"},
    {"psd_slope", G::Texture, true, "power-spectrum slope of tissue L*"},
    {"psd_hf_frac", G::Texture, true, "power at >= 12 cycles / 64 px"},
    {"lc16_med", G::Texture, true, "median local contrast (L* spread, 16 px)"},
    {"lc16_p90", G::Texture, true, "90th percentile local contrast"},
    {"lap_var", G::Texture, true, "variance of the Laplacian (sharpness)"},
    {"noise_sigma", G::Texture, true, "Immerkaer noise sigma (grey 0-255)"},
    {"ring0", G::Illumination, false, "mean L* at 0.0 <= r < 0.1"},
    {"ring1", G::Illumination, false, "mean L* at 0.1 <= r < 0.2"},
    {"ring2", G::Illumination, false, "mean L* at 0.2 <= r < 0.3"},
    {"ring3", G::Illumination, false, "mean L* at 0.3 <= r < 0.4"},
    {"ring4", G::Illumination, false, "mean L* at 0.4 <= r < 0.5"},
    {"ring5", G::Illumination, false, "mean L* at 0.5 <= r < 0.6"},
    {"ring6", G::Illumination, false, "mean L* at 0.6 <= r < 0.7"},
    {"ring7", G::Illumination, false, "mean L* at 0.7 <= r < 0.8"},
    {"ring8", G::Illumination, false, "mean L* at 0.8 <= r < 0.9"},
    {"ring9", G::Illumination, false, "mean L* at 0.9 <= r < 1.0"},
}};

// realism_stats.py's thresholds.
constexpr float kHighlightV = 0.92f, kHighlightS = 0.25f;
constexpr float kLumenL = 10.0f, kTissueMinL = 15.0f;
constexpr int kMinValid = 1000;

using Mask = std::vector<std::uint8_t>;

std::size_t at(int x, int y) {
    return static_cast<std::size_t>(y) * N + x;
}

// scipy.ndimage's binary dilation / erosion with the 4-connected cross,
// `iterations` times, outside the image 0 (the default border_value).
Mask morph(const Mask& in, int iterations, bool dilate) {
    Mask a = in, b(in.size());
    for (int it = 0; it < iterations; ++it) {
        for (int y = 0; y < N; ++y)
            for (int x = 0; x < N; ++x) {
                auto v = [&](int qx, int qy) -> bool {
                    return qx >= 0 && qy >= 0 && qx < N && qy < N && a[at(qx, qy)] != 0;
                };
                const bool c = v(x, y), l = v(x - 1, y), r = v(x + 1, y), u = v(x, y - 1), d = v(x, y + 1);
                b[at(x, y)] = dilate ? (c || l || r || u || d) : (c && l && r && u && d);
            }
        std::swap(a, b);
    }
    return a;
}

// sRGB -> CIELAB (D65) in float32, step by step as realism_stats.py's numpy code.
void srgbToLab(float r, float g, float b, float& L, float& A, float& B) {
    auto lin = [](float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); };
    const float lr = lin(r), lg = lin(g), lb = lin(b);
    float X = lr * 0.4124564f + lg * 0.3575761f + lb * 0.1804375f;
    float Y = lr * 0.2126729f + lg * 0.7151522f + lb * 0.0721750f;
    float Z = lr * 0.0193339f + lg * 0.1191920f + lb * 0.9503041f;
    X /= 0.95047f;
    Z /= 1.08883f;
    constexpr float e = 216.0f / 24389.0f, k = 24389.0f / 27.0f;
    auto f = [&](float t) { return t > e ? std::cbrt(t) : (k * t + 16.0f) / 116.0f; };
    const float fx = f(X), fy = f(Y), fz = f(Z);
    L = 116.0f * fy - 16.0f;
    A = 500.0f * (fx - fy);
    B = 200.0f * (fy - fz);
}

struct Moments {
    double sum = 0, sumSq = 0;
    long n = 0;
    void add(double v) {
        sum += v;
        sumSq += v * v;
        ++n;
    }
    double mean() const { return sum / static_cast<double>(n); }
    // Population variance (numpy's default ddof 0).
    double var() const { return std::max(0.0, sumSq / static_cast<double>(n) - mean() * mean()); }
};

// In-place radix-2 FFT of length 64.
void fft64(std::array<std::complex<double>, 64>& a) {
    constexpr int n = 64;
    for (int i = 1, j = 0; i < n; ++i) {
        int bit = n >> 1;
        for (; (j & bit) != 0; bit >>= 1) j ^= bit;
        j ^= bit;
        if (i < j) std::swap(a[static_cast<std::size_t>(i)], a[static_cast<std::size_t>(j)]);
    }
    for (int len = 2; len <= n; len <<= 1) {
        const double ang = -2.0 * std::numbers::pi / len;
        for (int i = 0; i < n; i += len)
            for (int k = 0; k < len / 2; ++k) {
                const std::complex<double> w = std::polar(1.0, ang * k);
                std::complex<double>& u = a[static_cast<std::size_t>(i + k)];
                std::complex<double>& v = a[static_cast<std::size_t>(i + k + len / 2)];
                const std::complex<double> t = w * v;
                v = u - t;
                u += t;
            }
    }
}

// Least-squares slope of y against x (numpy.polyfit, degree 1).
double slope(const std::vector<double>& x, const std::vector<double>& y) {
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        mx += x[i];
        my += y[i];
    }
    mx /= static_cast<double>(x.size());
    my /= static_cast<double>(y.size());
    double sxy = 0, sxx = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        sxy += (x[i] - mx) * (y[i] - my);
        sxx += (x[i] - mx) * (x[i] - mx);
    }
    return sxy / sxx;
}

// The texture statistics of the power spectrum: 64 px tiles at a 32 px
// stride, wholly inside the view and at least 90 % tissue (the rest filled
// with the tile's tissue mean), Hann-windowed; per tile the slope of the
// log radial power over 2..24 cycles and the share of power at >= 12 cycles;
// the medians over tiles.
void spectrum(const std::vector<float>& L, const Mask& valid, const Mask& tissue, FrameStats& s) {
    constexpr int T = 64;
    std::array<double, T> hann{};
    for (int i = 0; i < T; ++i)
        hann[static_cast<std::size_t>(i)] = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * i / (T - 1));
    // Radial bins: rint of the frequency's length (numpy's round half to even).
    std::array<int, T * T> bin{};
    std::array<double, T * T> kr{};
    std::array<int, T> binCount{};
    for (int v = 0; v < T; ++v)
        for (int u = 0; u < T; ++u) {
            const int fu = u < T / 2 ? u : u - T, fv = v < T / 2 ? v : v - T;
            const double r = std::hypot(static_cast<double>(fv), static_cast<double>(fu));
            const auto i = static_cast<std::size_t>(v * T + u);
            kr[i] = r;
            bin[i] = static_cast<int>(std::nearbyint(r));
            if (bin[i] < T) ++binCount[static_cast<std::size_t>(bin[i])];
        }
    std::vector<double> logK;
    for (int k = 2; k <= 24; ++k) logK.push_back(std::log(static_cast<double>(k)));
    std::vector<double> slopes, hfs;
    std::array<std::array<std::complex<double>, T>, T> F{};
    std::array<std::complex<double>, T> col{};
    for (int y0 = 0; y0 + T <= N; y0 += 32)
        for (int x0 = 0; x0 + T <= N; x0 += 32) {
            int nTissue = 0;
            bool allValid = true;
            double tissueSum = 0;
            for (int y = y0; y < y0 + T; ++y)
                for (int x = x0; x < x0 + T; ++x) {
                    allValid = allValid && valid[at(x, y)] != 0;
                    if (tissue[at(x, y)] != 0) {
                        ++nTissue;
                        tissueSum += L[at(x, y)];
                    }
                }
            if (!allValid || nTissue < 0.9 * T * T) continue;
            // The tile's tissue mean in float32, as numpy's tile[tm].mean() of a float64 copy: in double.
            const double fill = tissueSum / nTissue;
            double mean = 0;
            for (int y = y0; y < y0 + T; ++y)
                for (int x = x0; x < x0 + T; ++x) mean += tissue[at(x, y)] != 0 ? L[at(x, y)] : fill;
            mean /= T * T;
            for (int y = 0; y < T; ++y) {
                for (int x = 0; x < T; ++x) {
                    const double v = tissue[at(x0 + x, y0 + y)] != 0 ? L[at(x0 + x, y0 + y)] : fill;
                    F[static_cast<std::size_t>(y)][static_cast<std::size_t>(x)] =
                        (v - mean) * hann[static_cast<std::size_t>(y)] * hann[static_cast<std::size_t>(x)];
                }
                fft64(F[static_cast<std::size_t>(y)]);
            }
            for (int x = 0; x < T; ++x) {
                for (int y = 0; y < T; ++y)
                    col[static_cast<std::size_t>(y)] = F[static_cast<std::size_t>(y)][static_cast<std::size_t>(x)];
                fft64(col);
                for (int y = 0; y < T; ++y)
                    F[static_cast<std::size_t>(y)][static_cast<std::size_t>(x)] = col[static_cast<std::size_t>(y)];
            }
            std::array<double, T> prof{};
            double total = 0, high = 0;
            for (int v = 0; v < T; ++v)
                for (int u = 0; u < T; ++u) {
                    const double P = std::norm(F[static_cast<std::size_t>(v)][static_cast<std::size_t>(u)]);
                    const auto i = static_cast<std::size_t>(v * T + u);
                    if (bin[i] < T) prof[static_cast<std::size_t>(bin[i])] += P;
                    if (i != 0) total += P;
                    if (kr[i] >= 12) high += P;
                }
            std::vector<double> logP;
            bool positive = true;
            for (int k = 2; k <= 24; ++k) {
                const double p = prof[static_cast<std::size_t>(k)] / std::max(binCount[static_cast<std::size_t>(k)], 1);
                positive = positive && p > 0;
                logP.push_back(positive ? std::log(p) : 0.0);
            }
            if (!positive) continue;
            slopes.push_back(slope(logK, logP));
            if (total > 0) hfs.push_back(high / total);
        }
    if (!slopes.empty()) s[FrameStat::PsdSlope] = percentile(slopes, 50);
    if (!hfs.empty()) s[FrameStat::PsdHfFrac] = percentile(hfs, 50);
}

// A 3 x 3 convolution of `in` with edges replicated (ndimage mode 'nearest').
std::vector<double> convolve3(const std::vector<double>& in, const std::array<double, 9>& k) {
    std::vector<double> out(in.size());
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            double acc = 0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    acc += k[static_cast<std::size_t>((dy + 1) * 3 + dx + 1)] *
                           in[at(std::clamp(x + dx, 0, N - 1), std::clamp(y + dy, 0, N - 1))];
            out[at(x, y)] = acc;
        }
    return out;
}

}  // namespace

const FrameStatInfo& info(FrameStat s) noexcept {
    return kInfo[static_cast<std::size_t>(s)];
}

std::string_view groupName(StatGroup g) noexcept {
    switch (g) {
        case StatGroup::Colour:
            return "colour";
        case StatGroup::Highlight:
            return "highlight";
        case StatGroup::Illumination:
            return "illumination";
        case StatGroup::Texture:
            return "texture";
    }
    return "";
}

bool findFrameStat(std::string_view name, FrameStat& out) noexcept {
    for (int i = 0; i < kFrameStatCount; ++i)
        if (kInfo[static_cast<std::size_t>(i)].name == name) {
            out = static_cast<FrameStat>(i);
            return true;
        }
    return false;
}

FrameStats measureFrame(const image::Image8& frame, const image::Image8* mask) {
    if (frame.empty()) throw InputError("frame", "", "is empty");
    const image::Image8 rgb = squareResize(frame, kStatsSize);
    image::Image8 m;
    if (mask != nullptr && !mask->empty()) m = squareResize(*mask, kStatsSize);
    FrameStats s;
    s.values.fill(kNaN);
    // The highlight statistics, and the same classes here.
    const FrameHighlights h = measureHighlights(rgb, m.empty() ? nullptr : &m);
    const std::size_t n = static_cast<std::size_t>(N) * N;
    Mask valid(n), hl(n);
    std::vector<float> L(n), A(n), B(n);
    std::vector<double> radius(n);
    long nvalid = 0;
    const double c = (N - 1) / 2.0;
    const int ch = rgb.channels();
    auto channel = [&](int x, int y, int k) { return rgb.at(x, y, ch >= 3 ? k : 0) / 255.0f; };
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            const std::size_t i = at(x, y);
            radius[i] = std::hypot(y - c, x - c) / kStatsRadius;
            valid[i] = radius[i] < 1.0 && (m.empty() || m.at(x, y, 0) > 127);
            nvalid += valid[i];
            const float r = channel(x, y, 0), g = channel(x, y, 1), b = channel(x, y, 2);
            const float mx = std::max({r, g, b}), mn = std::min({r, g, b});
            const float sat = mx > 0 ? (mx - mn) / std::max(mx, 1e-6f) : 0.0f;
            hl[i] = valid[i] && mx > kHighlightV && sat < kHighlightS;
            srgbToLab(r, g, b, L[i], A[i], B[i]);
        }
    if (nvalid < kMinValid) return s;
    for (int k = 0; k < kHighlightStatCount; ++k)
        s.values[static_cast<std::size_t>(FrameStat::HlFrac) + static_cast<std::size_t>(k)] =
            h.values[static_cast<std::size_t>(k)];

    const Mask hlNear = morph(hl, 2, true);
    Mask tissue(n);
    long nTissue = 0;
    for (std::size_t i = 0; i < n; ++i) {
        tissue[i] = valid[i] && !hlNear[i] && L[i] >= kTissueMinL;
        nTissue += tissue[i];
    }

    // Colour of the tissue.
    if (nTissue > 200) {
        Moments l, a, b, rg, yb;
        double chroma = 0, cosSum = 0, sinSum = 0;
        for (int y = 0; y < N; ++y)
            for (int x = 0; x < N; ++x) {
                const std::size_t i = at(x, y);
                if (!tissue[i]) continue;
                l.add(L[i]);
                a.add(A[i]);
                b.add(B[i]);
                chroma += std::hypot(static_cast<double>(A[i]), static_cast<double>(B[i]));
                const double t = std::atan2(static_cast<double>(B[i]), static_cast<double>(A[i]));
                cosSum += std::cos(t);
                sinSum += std::sin(t);
                const double r8 = channel(x, y, 0) * 255.0, g8 = channel(x, y, 1) * 255.0,
                             b8 = channel(x, y, 2) * 255.0;
                rg.add(r8 - g8);
                yb.add(0.5 * (r8 + g8) - b8);
            }
        s[FrameStat::LMean] = l.mean();
        s[FrameStat::LStd] = std::sqrt(l.var());
        s[FrameStat::AMean] = a.mean();
        s[FrameStat::AStd] = std::sqrt(a.var());
        s[FrameStat::BMean] = b.mean();
        s[FrameStat::BStd] = std::sqrt(b.var());
        s[FrameStat::ChromaMean] = chroma / static_cast<double>(nTissue);
        const double C = cosSum / static_cast<double>(nTissue), S = sinSum / static_cast<double>(nTissue);
        const double R = std::hypot(C, S);
        s[FrameStat::HueMean] = std::atan2(S, C) * 180.0 / std::numbers::pi;
        s[FrameStat::HueStd] = std::sqrt(std::max(0.0, -2.0 * std::log(std::max(R, 1e-12)))) * 180.0 / std::numbers::pi;
        s[FrameStat::Colourfulness] =
            std::hypot(std::sqrt(rg.var()), std::sqrt(yb.var())) + 0.3 * std::hypot(rg.mean(), yb.mean());
    }

    // Illumination.
    {
        long dark = 0;
        Moments all;
        std::array<Moments, 10> rings;
        std::array<Moments, 3> bands;  // r < 0.3, 0.3..0.7, >= 0.7
        for (std::size_t i = 0; i < n; ++i) {
            if (!valid[i]) continue;
            dark += L[i] < kLumenL;
            all.add(L[i]);
            if (hl[i]) continue;
            const double r = radius[i];
            for (int k = 0; k < 10; ++k)
                if (r >= k / 10.0 && r < (k + 1) / 10.0) rings[static_cast<std::size_t>(k)].add(L[i]);
            bands[r < 0.3 ? 0 : (r < 0.7 ? 1 : 2)].add(L[i]);
        }
        s[FrameStat::DarkFrac] = static_cast<double>(dark) / static_cast<double>(nvalid);
        s[FrameStat::LAllMean] = all.mean();
        std::vector<double> rv;
        for (int k = 0; k < 10; ++k) {
            const Moments& mk = rings[static_cast<std::size_t>(k)];
            const double v = mk.n > 20 ? mk.mean() : kNaN;
            s.values[static_cast<std::size_t>(FrameStat::Ring0) + static_cast<std::size_t>(k)] = v;
            if (!std::isnan(v)) rv.push_back(v);
        }
        if (rv.size() >= 5) {
            const double med = percentile(rv, 50);
            if (med > 0.5) s[FrameStat::RingRatio] = *std::max_element(rv.begin(), rv.end()) / med;
        }
        constexpr std::array<FrameStat, 3> kBands = {FrameStat::BandInner, FrameStat::BandMid, FrameStat::BandOuter};
        for (std::size_t k = 0; k < 3; ++k)
            if (bands[k].n > 50) s[kBands[k]] = bands[k].mean();
    }

    // Texture of the tissue.
    spectrum(L, valid, tissue, s);
    std::vector<double> lcs;
    for (int y0 = 0; y0 + 16 <= N; y0 += 8)
        for (int x0 = 0; x0 + 16 <= N; x0 += 8) {
            Moments w;
            for (int y = y0; y < y0 + 16; ++y)
                for (int x = x0; x < x0 + 16; ++x)
                    if (tissue[at(x, y)]) w.add(L[at(x, y)]);
            if (static_cast<double>(w.n) >= 0.9 * 256) lcs.push_back(std::sqrt(w.var()));
        }
    if (lcs.size() >= 5) {
        s[FrameStat::Lc16Med] = percentile(lcs, 50);
        s[FrameStat::Lc16P90] = percentile(lcs, 90);
    }
    const Mask inner = morph(tissue, 2, false);
    long nInner = 0;
    for (std::uint8_t v : inner) nInner += v;
    if (nInner > 500) {
        std::vector<double> Ld(n), grey(n);
        for (int y = 0; y < N; ++y)
            for (int x = 0; x < N; ++x) {
                const std::size_t i = at(x, y);
                Ld[i] = L[i];
                grey[i] = static_cast<double>(
                    (0.299f * channel(x, y, 0) + 0.587f * channel(x, y, 1) + 0.114f * channel(x, y, 2)) * 255.0f);
            }
        const std::vector<double> lap = convolve3(Ld, {0, 1, 0, 1, -4, 1, 0, 1, 0});
        const std::vector<double> res = convolve3(grey, {1, -2, 1, -2, 4, -2, 1, -2, 1});
        Moments lv;
        double absSum = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (inner[i]) {
                lv.add(lap[i]);
                absSum += std::abs(res[i]);
            }
        s[FrameStat::LapVar] = lv.var();
        // Immerkaer 1996: sigma = sqrt(pi / 2) / 6 * mean |residual|.
        s[FrameStat::NoiseSigma] = std::sqrt(std::numbers::pi / 2) / 6.0 * absSum / static_cast<double>(nInner);
    }
    return s;
}

FrameStats measureFrameStatsFile(const fs::path& png) {
    const FrameFile f = readFrameFile(png);
    return measureFrame(f.frame, f.mask.empty() ? nullptr : &f.mask);
}

FrameStatsSummary summarise(const std::vector<FrameStats>& frames) {
    FrameStatsSummary s;
    s.frames = static_cast<int>(frames.size());
    for (std::size_t k = 0; k < kFrameStatCount; ++k) {
        std::vector<double> v;
        for (const FrameStats& f : frames)
            if (!std::isnan(f.values[k])) v.push_back(f.values[k]);
        StatSummary& st = s.stats[k];
        st.n = static_cast<int>(v.size());
        st.median = percentile(v, 50);
        st.q1 = percentile(v, 25);
        st.q3 = percentile(v, 75);
    }
    return s;
}

RealismScore realismScore(const FrameStatsSummary& ours, const FrameStatsSummary& target) {
    RealismScore r;
    r.perStat.fill(kNaN);
    std::array<double, 4> groupSum{};
    std::array<int, 4> groupTerms{};
    for (std::size_t k = 0; k < kFrameStatCount; ++k) {
        const double d = statDistance(ours.stats[k], target.stats[k]);
        r.perStat[k] = d;
        if (!kInfo[k].scored || std::isnan(d)) continue;
        r.overall += d;
        ++r.terms;
        const auto g = static_cast<std::size_t>(kInfo[k].group);
        groupSum[g] += d;
        ++groupTerms[g];
    }
    r.overall = r.terms > 0 ? r.overall / r.terms : kNaN;
    for (std::size_t g = 0; g < 4; ++g) r.perGroup[g] = groupTerms[g] > 0 ? groupSum[g] / groupTerms[g] : kNaN;
    return r;
}

namespace {

std::vector<FrameStats> readStatsJson(const fs::path& path) {
    const std::string file = path.string();
    const json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.is_object() || !j.contains("frames") || !j["frames"].is_array())
        throw InputError("frames", file, "a statistics file needs a \"frames\" array (realism_stats.py export)");
    std::vector<FrameStats> out;
    for (std::size_t i = 0; i < j["frames"].size(); ++i) {
        const json& f = j["frames"][i];
        const std::string where = fmt::format("frames[{}].stats", i);
        if (!f.is_object() || !f.contains("stats") || !f["stats"].is_object())
            throw InputError(where, file, "missing: each frame needs a \"stats\" object");
        FrameStats st;
        for (std::size_t k = 0; k < kFrameStatCount; ++k) {
            const std::string key(kInfo[k].name);
            const json* v = f["stats"].contains(key) ? &f["stats"][key] : nullptr;
            if (v == nullptr || v->is_null()) {
                st.values[k] = kNaN;
            } else if (v->is_number()) {
                st.values[k] = v->get<double>();
            } else {
                throw InputError(where + "." + key, file,
                                 std::string("must be a number or null, not ") + v->type_name());
            }
        }
        out.push_back(st);
    }
    if (out.empty()) throw InputError("frames", file, "is empty: no frames to take statistics from");
    return out;
}

}  // namespace

std::vector<FrameStats> readFrameStats(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw IoError("frames", path.string(), "no such file or folder");
    if (!fs::is_directory(path, ec)) return readStatsJson(path);
    std::vector<FrameStats> out;
    for (const fs::path& p : listFrames(path)) out.push_back(measureFrameStatsFile(p));
    return out;
}

}  // namespace mucosa::tune
