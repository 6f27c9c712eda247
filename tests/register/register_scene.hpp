#pragma once
// A synthetic bronchoscopy for the registration tests: a curved airway with
// bumps (so that no pose is ambiguous), frames along it with roll and
// forward motion, rendered with the lamp's inverse-square fall-off, a
// procedural albedo, specular glints, sensor noise and an exposure gain.
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::test {

struct RegisterScene {
    mesh::Mesh mesh;                  // the registration's model (the "CT"); normals face the lumen
    mesh::Mesh truth;                 // the same surface tessellated 2x finer: what the video sees
    std::vector<frames::Mat4> poses;  // camera_to_world, OpenCV axes, mm
};
RegisterScene makeRegisterScene(int frames = 8);

struct VideoOptions {
    frames::Vec3d lightOffset{0, 0, 0};
    double gain = 1.0;             // exposure
    double noise = 0.004;          // Gaussian sigma, linear
    double specular = 0.8;         // glint strength
    double albedoContrast = 0.25;  // 0: uniform albedo
    unsigned seed = 1;
    bool mask = true;  // circular field-of-view mask
};
// The albedo's factor at a surface point (world, mm): 1 + contrast x
// (blotches - vessels); the frames' RGB albedo is (0.85, 0.45, 0.35) x it.
double albedoFactor(const frames::Vec3d& pw, double contrast);
// Linear RGB (3 channels); `saturated` (optional) marks clipped pixels.
image::ImageF renderVideoFrame(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& pose,
                               const VideoOptions& o, int threads = 1, image::Image8* saturated = nullptr);

}  // namespace mucosa::test
