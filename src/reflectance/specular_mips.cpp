#include <mucosa/reflectance/specular_mips.hpp>

#include <algorithm>
#include <array>
#include <cmath>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::reflectance {

namespace {

using Vec = std::array<float, 3>;

std::uint8_t encode(double c) {
    return static_cast<std::uint8_t>(std::clamp(std::floor((0.5 * c + 0.5) * 255.0 + 0.5), 0.0, 255.0));
}

// rgb = 0.5 normalize(Na) + 0.5, alpha = sigma / kMapSigmaMax with Toksvig's
// sigma^2 = (1 - |Na|) / |Na|.
void store(image::Image8& img, int x, int y, const Vec& na) {
    const double len = std::sqrt(double(na[0]) * na[0] + double(na[1]) * na[1] + double(na[2]) * na[2]);
    const double inv = len > 1e-12 ? 1.0 / len : 0.0;
    const double l = std::clamp(len, 1e-6, 1.0);
    const double sigma = std::sqrt((1.0 - l) / l);
    img.at(x, y, 0) = encode(na[0] * inv);
    img.at(x, y, 1) = encode(na[1] * inv);
    img.at(x, y, 2) = len > 1e-12 ? encode(na[2] * inv) : 255;
    img.at(x, y, 3) = static_cast<std::uint8_t>(std::lround(std::min(sigma / kMapSigmaMax, 1.0) * 255.0));
}

}  // namespace

std::vector<image::Image8> specularMipChain(const image::Image8& map) {
    if (map.empty() || map.channels() < 3) throw InputError("reflectance map", "", "needs an RGB image");
    const int w0 = map.width(), h0 = map.height();
    // The chain (4/3 of level 0 in RGBA8) and the float averages of level 1.
    const std::uint64_t texels = saturatingMul(static_cast<std::uint64_t>(w0), static_cast<std::uint64_t>(h0));
    requireMemory(saturatingMul(texels, 4 * 4 / 3 + 1 + 3), "reflectance map mip chain");
    std::vector<image::Image8> levels;
    image::Image8 base(w0, h0, 4);
    for (int y = 0; y < h0; ++y)
        for (int x = 0; x < w0; ++x) {
            for (int c = 0; c < 3; ++c) base.at(x, y, c) = map.at(x, y, c);
            base.at(x, y, 3) = 0;
        }
    levels.push_back(std::move(base));
    // Level 0's unit normals, decoded on the fly (8-bit texels are unit only
    // to within quantisation, so they are renormalised).
    const auto unit = [&](int x, int y) {
        Vec n;
        for (int c = 0; c < 3; ++c) n[static_cast<std::size_t>(c)] = map.at(x, y, c) / 127.5f - 1.0f;
        const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0) n = {n[0] / len, n[1] / len, n[2] / len};
        return n;
    };
    std::vector<Vec> cur;  // the previous level's unnormalised averages (level >= 1)
    int w = w0, h = h0;
    while (w > 1 || h > 1) {
        const int nw = std::max(1, w / 2), nh = std::max(1, h / 2);
        std::vector<Vec> next(static_cast<std::size_t>(nw) * nh);
        image::Image8 img(nw, nh, 4);
        for (int y = 0; y < nh; ++y)
            for (int x = 0; x < nw; ++x) {
                // The 2 x 2 block (1 wide or high where the level above is).
                Vec sum{0, 0, 0};
                int count = 0;
                for (int dy = 0; dy < (h > 1 ? 2 : 1); ++dy)
                    for (int dx = 0; dx < (w > 1 ? 2 : 1); ++dx) {
                        const int sx = std::min(2 * x + dx, w - 1), sy = std::min(2 * y + dy, h - 1);
                        const Vec n = levels.size() == 1 ? unit(sx, sy) : cur[static_cast<std::size_t>(sy) * w + sx];
                        for (int c = 0; c < 3; ++c) sum[static_cast<std::size_t>(c)] += n[static_cast<std::size_t>(c)];
                        ++count;
                    }
                for (float& c : sum) c /= static_cast<float>(count);
                next[static_cast<std::size_t>(y) * nw + x] = sum;
                store(img, x, y, sum);
            }
        levels.push_back(std::move(img));
        cur = std::move(next);
        w = nw;
        h = nh;
    }
    return levels;
}

double mipSlopeVariance(const image::Image8& level, int x, int y) noexcept {
    const double sigma = level.at(x, y, 3) / 255.0 * kMapSigmaMax;
    return sigma * sigma;
}

}  // namespace mucosa::reflectance
