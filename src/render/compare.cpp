// mucosa compare: the paper's Figures 2 and 3 as one labelled picture.
#include <mucosa/render/offscreen.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <fmt/format.h>
#include <stb/stb_easy_font.h>

#include <mucosa/image/png.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/normal_map.hpp>

namespace mucosa::render {

namespace {

void blit(image::Image8& dst, const image::Image8& src, int x0, int y0) {
    for (int y = 0; y < src.height(); ++y)
        std::memcpy(dst.row(y0 + y) + static_cast<std::size_t>(x0) * 3, src.row(y), src.rowStride());
}

void fill(image::Image8& img, int x0, int y0, int w, int h, std::array<std::uint8_t, 3> c) {
    for (int y = std::max(0, y0); y < std::min(img.height(), y0 + h); ++y)
        for (int x = std::max(0, x0); x < std::min(img.width(), x0 + w); ++x)
            for (int k = 0; k < 3; ++k) img.at(x, y, k) = c[static_cast<std::size_t>(k)];
}

image::Image8 generateMap(reflectance::MapParams p) {
    const image::ImageF h = reflectance::heightField(p);
    return reflectance::encodeNormals8(h, p.strength,
                                       p.noise.tileable ? reflectance::Edges::Wrap : reflectance::Edges::Clamp);
}

}  // namespace

void drawText(image::Image8& img, int x, int y, const std::string& text, std::array<std::uint8_t, 3> color, int scale) {
    std::vector<char> buffer(text.size() * 300 + 64);
    std::string copy = text;
    unsigned char rgba[4] = {255, 255, 255, 255};
    const int quads = stb_easy_font_print(0, 0, copy.data(), rgba, buffer.data(), static_cast<int>(buffer.size()));
    for (int q = 0; q < quads; ++q) {
        float xs[4], ys[4];
        for (int v = 0; v < 4; ++v) {
            const char* p = buffer.data() + (q * 4 + v) * 16;
            std::memcpy(&xs[v], p, 4);
            std::memcpy(&ys[v], p + 4, 4);
        }
        const int qx0 = static_cast<int>(std::lround(*std::min_element(xs, xs + 4))) * scale;
        const int qx1 = static_cast<int>(std::lround(*std::max_element(xs, xs + 4))) * scale;
        const int qy0 = static_cast<int>(std::lround(*std::min_element(ys, ys + 4))) * scale;
        const int qy1 = static_cast<int>(std::lround(*std::max_element(ys, ys + 4))) * scale;
        fill(img, x + qx0, y + qy0, qx1 - qx0, qy1 - qy0, color);
    }
}

image::Image8 compareSheet(const scene::Scene& scene, const scene::SceneAssets& assets, const CompareOptions& o) {
    const int tw = o.tileWidth, th = o.tileHeight;
    const int cols = 7;
    const int labelW = 190, headerH = 64, colHeadH = 30, gap = 6;
    const shading::Mode modes[cols] = {shading::Mode::Noise,
                                       shading::Mode::Procedural,
                                       shading::Mode::VertexPhong,
                                       shading::Mode::Multitexture,
                                       shading::Mode::Diffuse,
                                       shading::Mode::Clearcoat,
                                       shading::Mode::ClearcoatProcedural};
    const int views = std::max(1, o.views);
    const int rows = views + 3;  // views, frequency row, anti-aliasing row, coarse patch
    const int width = labelW + cols * (tw + gap) + gap;
    const int height = headerH + colHeadH + rows * (th + gap) + colHeadH + gap;
    image::Image8 sheet(width, height, 3);
    fill(sheet, 0, 0, width, height, {24, 24, 28});
    const std::array<std::uint8_t, 3> white{235, 235, 235}, grey{170, 170, 175};
    drawText(sheet, gap, 10, "Mucosa: noise-based reflectance vs. the paper's baselines (Fig. 2, 3)", white, 2);
    drawText(sheet, gap, 36,
             fmt::format("same views, every mode; reflectance map '{}' ({}x{}); shininess {}, k_s {}",
                         scene.mapParams.preset.empty() ? "custom" : scene.mapParams.preset, scene.mapParams.size,
                         scene.mapParams.size, scene.params[shading::Param::Shininess],
                         scene.params[shading::Param::SpecularStrength]),
             grey, 1);
    const int total = views * cols + static_cast<int>(o.frequencies.size()) + 4 + cols;
    int done = 0;
    auto tick = [&] {
        ++done;
        if (o.progress) o.progress(done, total);
    };
    auto cellX = [&](int c) { return labelW + gap + c * (tw + gap); };
    auto cellY = [&](int r, int extraHeads) { return headerH + colHeadH + extraHeads * colHeadH + r * (th + gap); };
    for (int c = 0; c < cols; ++c)
        drawText(sheet, cellX(c), headerH + 6, std::string(shading::modeName(modes[c])), white, 2);

    OffscreenSession session(scene, assets, tw, th);
    // Views spread along one path down the tree (the middle part, away from
    // the ends), looking ahead into the lumen as the paper's figures do: the
    // survey's views, turned to the walls, show the modes' highlights less.
    scene::Scene onePath = scene;
    onePath.path.survey = false;
    const std::vector<camera::Pose> path = scene::cameraPoses(onePath, assets, 9);
    std::vector<camera::Pose> viewPoses;
    for (int v = 0; v < views; ++v) {
        const int idx = views == 1 ? 2 : 1 + v * 5 / std::max(1, views - 1);
        viewPoses.push_back(path[static_cast<std::size_t>(std::min<int>(idx, static_cast<int>(path.size()) - 1))]);
    }
    if (scene.pose) viewPoses[0] = *scene.pose;
    for (int v = 0; v < views; ++v) {
        drawText(sheet, gap, cellY(v, 0) + th / 2 - 8, fmt::format("view {}", v + 1), white, 2);
        for (int c = 0; c < cols; ++c) {
            blit(sheet, session.render(viewPoses[static_cast<std::size_t>(v)], modes[c]), cellX(c), cellY(v, 0));
            tick();
        }
    }
    // Fig. 3: noise frequency.
    const int fr = views;
    drawText(sheet, gap, cellY(fr, 0) + th / 2 - 20, "map", white, 2);
    drawText(sheet, gap, cellY(fr, 0) + th / 2 + 4, "frequency", white, 2);
    drawText(sheet, gap, cellY(fr, 0) + th / 2 + 28, "(noise mode, view 1)", grey, 1);
    reflectance::MapParams mp = scene.reflectanceMap ? reflectance::findPreset("bronchial").params : scene.mapParams;
    mp.bits = 8;
    const int nf = std::min<int>(cols, static_cast<int>(o.frequencies.size()));
    for (int c = 0; c < nf; ++c) {
        reflectance::MapParams p = mp;
        p.noise.frequency = o.frequencies[static_cast<std::size_t>(c)];
        p.size = std::min(p.size, 1024);
        session.setReflectanceMap(generateMap(p));
        const image::Image8 tile = session.render(viewPoses[0], shading::Mode::Noise);
        blit(sheet, tile, cellX(c), cellY(fr, 0));
        drawText(sheet, cellX(c) + 8, cellY(fr, 0) + th - 22, fmt::format("frequency {}", p.noise.frequency), white, 1);
        tick();
    }
    session.setReflectanceMap(assets.reflectanceMap);
    // Specular anti-aliasing off / on for both paths: the distant
    // walls sparkle without it.
    const int ar = views + 1;
    drawText(sheet, gap, cellY(ar, 0) + th / 2 - 20, "specular", white, 2);
    drawText(sheet, gap, cellY(ar, 0) + th / 2 + 4, "anti-aliasing", white, 2);
    drawText(sheet, gap, cellY(ar, 0) + th / 2 + 28, "(view 1)", grey, 1);
    for (int c = 0; c < 4; ++c) {
        shading::FrameSetup f = scene::frameSetup(scene, viewPoses[0], tw, th);
        f.mode = c < 2 ? shading::Mode::Noise : shading::Mode::Procedural;
        f.specularAA = c % 2 == 1;
        blit(sheet, session.renderFrame(f), cellX(c), cellY(ar, 0));
        drawText(sheet, cellX(c) + 8, cellY(ar, 0) + th - 22,
                 fmt::format("{}, AA {}", c < 2 ? "map" : "procedural", f.specularAA ? "on" : "off"), white, 1);
        tick();
    }
    // A coarse surface patch: per-vertex lighting shows facets and polygonal highlights.
    const int pr = views + 2;
    drawText(sheet, gap, cellY(pr, 0) + th / 2 - 20, "coarse", white, 2);
    drawText(sheet, gap, cellY(pr, 0) + th / 2 + 4, "patch", white, 2);
    drawText(sheet, gap, cellY(pr, 0) + th / 2 + 28, "(16 x 40 quads)", grey, 1);
    const mesh::Mesh tube = mesh::makeTube(7.0f, 150.0f, 16, 40);
    session.renderer().setMesh(tube);
    const camera::Pose patchPose = camera::lookAt({0.0f, -3.0f, -30.0f}, {0.0f, 7.0f, -40.0f});
    for (int c = 0; c < cols; ++c) {
        blit(sheet, session.render(patchPose, modes[c]), cellX(c), cellY(pr, 0));
        tick();
    }
    session.renderer().setMesh(assets.mesh);
    drawText(sheet, gap, cellY(rows, 0) + 8,
             "noise: per-pixel specular from the reflectance map | procedural: the map's noise evaluated per pixel | "
             "vertex-phong: per-vertex Phong (Gouraud) | multitexture: per-vertex light + sphere-mapped highlight "
             "texture | diffuse: no specular | clearcoat: glTF's clear coat on the map's normals | "
             "clearcoat-procedural: the coat on the procedural noise's normals",
             grey, 1);
    return sheet;
}

void writeDefaultCompareSheet(const std::filesystem::path& png, int threads) {
    const scene::Scene scene = scene::defaultScene();
    const scene::SceneAssets assets = scene::loadAssets(scene, threads);
    image::writePng(png, compareSheet(scene, assets));
}

HighlightStats highlightStats(const image::Image8& rgb, int threshold, int minArea) {
    const int w = rgb.width(), h = rgb.height();
    std::vector<std::uint8_t> in(static_cast<std::size_t>(w) * h, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            int m = 255;
            for (int c = 0; c < std::min(3, rgb.channels()); ++c) m = std::min<int>(m, rgb.at(x, y, c));
            in[static_cast<std::size_t>(y) * w + x] = m >= threshold;
        }
    auto at = [&](int x, int y) {
        return x >= 0 && y >= 0 && x < w && y < h && in[static_cast<std::size_t>(y) * w + x];
    };
    std::vector<int> label(in.size(), -1);
    HighlightStats s;
    double sumIso = 0, sumWeighted = 0;
    std::vector<std::pair<int, int>> stack;
    for (int y0 = 0; y0 < h; ++y0)
        for (int x0 = 0; x0 < w; ++x0) {
            const std::size_t i0 = static_cast<std::size_t>(y0) * w + x0;
            if (!in[i0] || label[i0] >= 0) continue;
            long area = 0, perimeter = 0;
            stack.assign(1, {x0, y0});
            label[i0] = 1;
            while (!stack.empty()) {
                const auto [x, y] = stack.back();
                stack.pop_back();
                ++area;
                perimeter += !at(x - 1, y) + !at(x + 1, y) + !at(x, y - 1) + !at(x, y + 1);
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        if (!at(x + dx, y + dy)) continue;
                        const std::size_t j = static_cast<std::size_t>(y + dy) * w + (x + dx);
                        if (label[j] >= 0) continue;
                        label[j] = 1;
                        stack.push_back({x + dx, y + dy});
                    }
            }
            if (area < minArea) continue;
            const double iso = double(perimeter) * double(perimeter) / double(area);
            ++s.components;
            s.totalArea += double(area);
            sumIso += iso;
            sumWeighted += iso * double(area);
        }
    if (s.components > 0) {
        s.meanIsoperimetric = sumIso / s.components;
        s.weightedIsoperimetric = sumWeighted / s.totalArea;
    }
    return s;
}

}  // namespace mucosa::render
