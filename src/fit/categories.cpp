#include <mucosa/fit/categories.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

#include "core/json_parse.hpp"

namespace mucosa::fit {

namespace fs = std::filesystem;
using json = nlohmann::json;

FittedModel readFitDirectory(const fs::path& dir) {
    FittedModel m;
    const fs::path brdfPath = dir / "brdf.json";
    m.brdf = shading::readBrdf(brdfPath);
    const json j = detail::parseJsonFile(readTextFile(brdfPath), brdfPath.string());
    for (int i = 0; i < 2; ++i) {
        if (j.contains("uv_min")) m.uvMin[static_cast<std::size_t>(i)] = j["uv_min"][i].get<float>();
        if (j.contains("uv_max")) m.uvMax[static_cast<std::size_t>(i)] = j["uv_max"][i].get<float>();
    }
    const image::PngImage png = image::readPng(dir / "texture.png");
    if (png.pixels.channels() < 3) throw InputError("texture", (dir / "texture.png").string(), "must be RGB");
    const double maxv = png.bitDepth == 16 ? 65535.0 : 255.0;
    m.texture = image::ImageF(png.pixels.width(), png.pixels.height(), 3);
    for (int y = 0; y < png.pixels.height(); ++y)
        for (int x = 0; x < png.pixels.width(); ++x)
            for (int c = 0; c < 3; ++c) m.texture.at(x, y, c) = static_cast<float>(png.pixels.at(x, y, c) / maxv);
    return m;
}

namespace {

image::Image8 toImage8(const image::ImageF& linear, double gamma) {
    image::Image8 out(linear.width(), linear.height(), linear.channels());
    for (std::size_t i = 0; i < out.size(); ++i) {
        double v = std::clamp(static_cast<double>(linear.data()[i]), 0.0, 1.0);
        if (gamma != 1.0) v = std::pow(v, 1.0 / gamma);
        out.data()[i] = static_cast<std::uint8_t>(std::lround(v * 255.0));
    }
    return out;
}

// Categories 2-4 as the scope shows a frame: the fitted model's linear
// signal (an unrecorded exposure is in the albedo, and so is any colour
// processing the scope did that the frames file does not name) through the
// frames' own response, the inverse of what `mucosa fit` did to read them:
// the frame's recorded exposure (`gain`) and the vignetting cos^k put back,
// clipping at 1, the tone curve, the colour enhancement ("saturation"); and
// black where the real frame is outside the scope's field of view (its own
// mask, whatever its shape).
image::Image8 develop(const image::ImageF& linear, const frames::Intrinsics& K, const frames::Response& response,
                      double gain, const std::vector<std::uint8_t>& outside) {
    image::Image8 out(linear.width(), linear.height(), 3);
    for (int y = 0; y < linear.height(); ++y)
        for (int x = 0; x < linear.width(); ++x) {
            if (outside[static_cast<std::size_t>(y) * linear.width() + x]) continue;
            const double vignette = response.vignette(K, x, y) * gain;
            std::array<double, 3> v{};
            for (int c = 0; c < 3; ++c)
                v[static_cast<std::size_t>(c)] = response.encode(std::clamp(linear.at(x, y, c) * vignette, 0.0, 1.0));
            v = response.enhance(v);
            for (int c = 0; c < 3; ++c)
                out.at(x, y, c) = static_cast<std::uint8_t>(std::lround(255.0 * v[static_cast<std::size_t>(c)]));
        }
    return out;
}

image::Image8 reduce(const image::Image8& img, int divisor) {
    const int w = std::max(1, img.width() / divisor), h = std::max(1, img.height() / divisor);
    image::Image8 out(w, h, img.channels());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < img.channels(); ++c) {
                int sum = 0, n = 0;
                for (int yy = y * divisor; yy < std::min(img.height(), (y + 1) * divisor); ++yy)
                    for (int xx = x * divisor; xx < std::min(img.width(), (x + 1) * divisor); ++xx) {
                        sum += img.at(xx, yy, c);
                        ++n;
                    }
                out.at(x, y, c) = static_cast<std::uint8_t>((sum + n / 2) / std::max(1, n));
            }
    return out;
}

}  // namespace

std::vector<CategoryImage> renderCategories(mesh::Mesh mesh, const frames::FrameSet& frames, const FittedModel& model,
                                            const fs::path& outDir, const CategoriesOptions& o) {
    if (!mesh.hasUvs()) throw InputError("mesh", "", "has no texture coordinates (use the mesh the fit used)");
    // The atlas spans uvMin..uvMax: the subject texture is looked up through
    // the frame's UV transform, while the reflectance map of category 4 keeps
    // the mesh's own coordinates. (Rescaling the mesh's UVs into the atlas
    // square instead squeezed the map along the longer side of the UV
    // rectangle, 4-5x along a phantom's airway, and its highlights came out
    // as streaks along the tube: radial in a view down the lumen.)
    const float du = model.uvMax[0] - model.uvMin[0], dv = model.uvMax[1] - model.uvMin[1];
    const std::array<float, 4> atlasTransform{1.0f / du, 1.0f / dv, -model.uvMin[0] / du, -model.uvMin[1] / dv};
    mesh::computeTangents(mesh, o.threads);
    std::error_code ec;
    fs::create_directories(outDir, ec);
    if (ec) throw IoError("output directory", outDir.string(), ec.message());

    // Check every frame before rendering anything.
    // (The header only: each frame is decoded once, for its field of view, below.)
    for (const frames::Frame& f : frames.frames) {
        const image::PngHeader real = image::readPngHeader(f.image);
        if (real.width != f.K.width || real.height != f.K.height)
            throw InputError("image size", f.image.string(),
                             fmt::format("is {}x{} but the frame's intrinsics say {}x{}", real.width, real.height,
                                         f.K.width, f.K.height));
    }

    render::HeadlessContext context;
    render::Renderer renderer;
    renderer.setMesh(mesh);
    const image::Image8 atlas = toImage8(model.texture, 1.0);
    const image::Image8 lowRes = reduce(atlas, std::max(1, o.lowResDivisor));
    reflectance::MapParams mp = reflectance::findPreset(o.preset).params;
    mp.size = 1024;
    const image::Image8 map = reflectance::encodeNormals8(reflectance::heightField(mp, o.threads), mp.strength,
                                                          reflectance::Edges::Wrap, o.threads);
    renderer.setTexture(render::TextureSlot::Reflectance, map, shading::Filter::Trilinear, shading::Wrap::Repeat);

    // The fitted model: I = albedo rho(gamma) delta(r), nothing else (no
    // ambient, no mucus tint, no extra fall-off: delta is the fall-off).
    shading::ParamSet fitted;
    using P = shading::Param;
    fitted.set(P::C0, static_cast<float>(model.brdf.c[0]));
    fitted.set(P::C1, static_cast<float>(model.brdf.c[1]));
    fitted.set(P::C2, static_cast<float>(model.brdf.c[2]));
    fitted.set(P::C3, static_cast<float>(model.brdf.c[3]));
    fitted.set(P::D1, static_cast<float>(model.brdf.d[0]));
    fitted.set(P::D2, static_cast<float>(model.brdf.d[1]));
    fitted.set(P::D3, static_cast<float>(model.brdf.d[2]));
    fitted.set(P::DepthMin, static_cast<float>(model.brdf.zmin));
    fitted.set(P::DepthMax, static_cast<float>(model.brdf.zmax));
    fitted.set(P::Ambient, 0.0f);
    fitted.set(P::MucusOpacity, 0.0f);
    fitted.setColor(P::BaseColor, {1.0f, 1.0f, 1.0f});
    fitted.set(P::LightIntensity, 1.0f);
    fitted.set(P::MapTiling, static_cast<float>(o.mapTiling));
    const shading::ParamSet unreal;  // the registry's defaults, flat colour, plain Phong

    // Each image is written atomically as soon as it is rendered; the manifest
    // comes last, so an interrupted run leaves complete images and no manifest.
    std::vector<CategoryImage> out;
    const int total = static_cast<int>(frames.frames.size());
    for (int i = 0; i < total; ++i) {
        const frames::Frame& f = frames.frames[static_cast<std::size_t>(i)];
        render::Framebuffer fb(f.K.width, f.K.height);
        render::Framebuffer linear(f.K.width, f.K.height, render::ColorFormat::Rgba16F);
        const std::vector<std::uint8_t> outside = outsideFieldOfView(loadFrameImage(f, frames.response));
        shading::FrameSetup setup;
        setup.view = frames::glViewMatrix(f.cameraToWorld);
        setup.projection = frames::glProjectionMatrix(f.K, 0.5, 500.0);
        const frames::Vec3d eye = frames::cameraCentre(f.cameraToWorld);
        const frames::Vec3d light = frames::transformPoint(f.cameraToWorld, frames.lightOffset);
        setup.eye = {static_cast<float>(eye[0]), static_cast<float>(eye[1]), static_cast<float>(eye[2])};
        setup.light = {static_cast<float>(light[0]), static_cast<float>(light[1]), static_cast<float>(light[2])};
        setup.width = f.K.width;
        setup.height = f.K.height;
        setup.diffuseUvTransform = atlasTransform;
        auto shoot = [&](int category, shading::Mode mode, const shading::ParamSet& params) {
            setup.mode = mode;
            setup.params = params;
            // Category 1 goes through Mucosa's own camera (a photographic
            // mode); the fitted ones are the frames' signal, developed here.
            const bool photographic = shading::info(mode).photographic;
            (photographic ? fb : linear).bind();
            renderer.draw(setup);
            const image::Image8 img = photographic ? fb.readRgb()
                                                   : develop(linear.readRgbLinear(), f.K, frames.response,
                                                             f.exposure > 0 ? f.exposure : 1.0, outside);
            CategoryImage ci{fmt::format("p{:03}_c{}", i, category), fmt::format("pose{:03}_cat{}.png", i, category),
                             category, i};
            image::writePng(outDir / ci.file, img);
            out.push_back(ci);
        };
        renderer.clearTexture(render::TextureSlot::Diffuse);
        shoot(1, shading::Mode::VertexPhong, unreal);
        renderer.setTexture(render::TextureSlot::Diffuse, lowRes, shading::Filter::Linear, shading::Wrap::Clamp);
        shoot(2, shading::Mode::Brdf, fitted);
        renderer.setTexture(render::TextureSlot::Diffuse, atlas, shading::Filter::Trilinear, shading::Wrap::Clamp);
        shoot(3, shading::Mode::Brdf, fitted);
        shoot(4, shading::Mode::BrdfNoise, fitted);
        CategoryImage real{fmt::format("p{:03}_c5", i),
                           fmt::format("pose{:03}_cat5{}", i, f.image.extension().string()), 5, i};
        writeFileAtomic(outDir / real.file, readFile(f.image));
        out.push_back(real);
        if (o.progress) o.progress(i + 1, total);
    }
    json manifest{{"images", json::array()}};
    for (const CategoryImage& c : out)
        manifest["images"].push_back({{"id", c.id},
                                      {"file", c.file.string()},
                                      {"category", c.category},
                                      {"patient", o.patient},
                                      {"pose", fmt::format("{:03}", c.pose)}});
    writeFileAtomic(outDir / "images.json", manifest.dump(2) + "\n");
    return out;
}

}  // namespace mucosa::fit
