// Maps, tangents and the shading maths through mucosa::core only: a reflectance
// map from the bronchial preset, tangent frames on a quad, and one frame of
// the method (noise mode) drawn by the C++ reference of the shaders, no GL.
#include <cstdio>

#include <mucosa/camera/camera.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/shading/reference.hpp>

using namespace mucosa;

int main() {
    reflectance::MapParams p = reflectance::findPreset("bronchial").params;
    p.size = 128;
    const image::Image8 map = reflectance::encodeNormals8(reflectance::heightField(p), p.strength,
                                                          reflectance::Edges::Wrap);

    mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    quad.tangents.clear();
    const mesh::TangentReport tangents = mesh::computeTangents(quad);
    if (quad.tangents.size() != quad.positions.size()) return 2;

    shading::FrameSetup f;
    f.width = 96;
    f.height = 96;
    const camera::Pose pose = camera::lookAt({0, 0, 30}, {0, 0, 0});
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(camera::Lens{}, f.width, f.height);
    f.eye = {0, 0, 30};
    f.light = {0, 0, 30};
    f.mode = shading::Mode::Noise;
    shading::Textures t;
    t.reflectance = {&map, shading::Filter::Linear, shading::Wrap::Repeat};
    const image::Image8 frame = shading::renderReference(quad, f, t);

    double sum = 0;
    for (int y = 0; y < frame.height(); ++y)
        for (int x = 0; x < frame.width(); ++x) sum += frame.at(x, y, 0);
    const double mean = sum / (frame.width() * frame.height());
    std::printf("core consumer: map %dx%d, %zu tangents, frame %dx%d, mean red %.1f\n", map.width(), map.height(),
                quad.tangents.size(), frame.width(), frame.height(), mean);
    (void)tangents;
    return mean > 10.0 ? 0 : 3;
}
