#pragma once
// Per-frame ground truth of a rendered endoscope frame: metric depth, surface
// normals, the triangle and texture coordinates each pixel sees, and the
// pixels that see a surface. Computed exactly from the mesh and the camera
// (for a pinhole a z-buffer at the pixel centres, raster::rasterize; through a
// lens each pixel centre's ray cast into the mesh, raycast.hpp), not read
// back from the colour render, so it does not depend on the GL driver's
// precision; the colour frame is rendered with the same intrinsics (or the
// same lens's rays) and pose (frames::glProjectionMatrix), so the two align
// pixel for pixel.
//
// Conventions (written into every dataset manifest, docs/datasets.md):
// OpenCV camera axes (x right, y down, z forward), pixel centres at integer
// coordinates, millimetres, row-major camera_to_world.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include <mucosa/camera/camera.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/reference.hpp>

namespace mucosa::dataset {

// The outputs a dataset frame can have (`--outputs rgb,depth,...`).
struct Outputs {
    bool rgb = true;
    int rgbBits = 8;       // the colour frame's PNG: 8 or 16 bits per channel
    bool depth = false;    // planar z in mm: float32 EXR + 16-bit PNG with a declared scale
    bool normals = false;  // camera space, OpenCV axes: float32 EXR + 16-bit PNG
    bool mask = false;     // the pixels that see a surface: 8-bit PNG
    bool uv = false;       // the mesh's texture coordinates: float32 EXR
    bool face = false;     // the triangle index: float32 EXR (exact up to 2^24)
    bool flow = false;     // optical flow to the previous frame and its occlusion: float32 EXR + 8-bit PNG
    bool branch = false;   // the airway branch seen (segmentation labels from the centerline): 16-bit PNG
    // Drawn by the renderer with the colour frame's exposure:
    bool linear = false;     // the camera's linear signal (before the tone curve): float32 EXR
    bool highlight = false;  // the specular-highlight pixels: 8-bit PNG
    // Each colour frame's record, OUT_NNNN.frame.json: the exposure the
    // camera gave it (auto-exposure changes it frame by frame), which
    // `mucosa fit` divides out. Written by every dataset (a run with outputs,
    // or a plan's); not by a plain sequence of frames.
    bool record = false;
    // How the float EXRs are compressed (lossless; image::ExrCompression).
    image::ExrCompression exrCompression = image::ExrCompression::Zip;
    bool any() const noexcept { return depth || normals || mask || uv || face || flow || branch; }  // any ground truth
};
// Whether the frames have a record (Outputs::record, and a colour output).
inline bool hasRecord(const Outputs& o) noexcept {
    return o.record && (o.rgb || o.linear || o.highlight);
}
// A frame's record: {"frame": index, "exposure": the linear gain the camera
// applied to the frame's signal (2^EV), "exposure_ev": its log2}. The
// non-photographic modes (brdf, the debug views) have no camera: 1 and 0.
nlohmann::json frameRecord(int index, double exposure);
// out_0012.png -> out_0012.frame.json.
std::filesystem::path recordFile(const std::filesystem::path& rgbName);
// The exposure in a record file; throws InputError naming the file.
double readFrameExposure(const std::filesystem::path& path);

// The highlight mask: a pixel is a specular highlight where the specular
// lobe (material.specular_strength) adds at least this much, of full scale,
// to the noise-free linear signal's luminance (after the sensor clips: a
// glint on a saturated wall adds nothing visible and is not one).
inline constexpr float kHighlightMinSignal = 0.05f;
// 255 / 0 per pixel from the linear signal with and without the specular
// lobe (3-channel images, Rec. 709 luminance).
image::Image8 highlightMask(const image::ImageF& withSpecular, const image::ImageF& withoutSpecular);

// "rgb,depth,normals": throws InputError naming `what` and `where` for an
// unknown or repeated name or an empty list.
Outputs parseOutputs(std::string_view list, const std::string& what, const std::string& where);
std::string outputNames(const Outputs& outputs);  // "rgb,depth,normals"

// The renderer's camera in OpenCV terms: the pinhole intrinsics of a lens
// whose field of view spans the image's larger dimension
// (camera::projectionMatrix), and the camera_to_world of a pose.
frames::Intrinsics intrinsicsOf(const camera::Lens& lens, int width, int height);
frames::Mat4 cameraToWorldOf(const camera::Pose& pose);

struct GroundTruth {
    int width = 0, height = 0;
    image::ImageF depth;              // 1 channel: planar z along the optical axis, mm; 0 where no surface
    image::ImageF normals;            // 3 channels: unit, camera space, facing the camera; 0 where no surface
    image::ImageF uv;                 // 3 channels: u, v (OpenGL texture space, v up), 1; 0 where no surface or no UVs
    std::vector<std::int32_t> face;   // triangle index; -1 where no surface
    std::vector<float> b1, b2;        // barycentrics of the triangle's vertices 1 and 2 at the pixel
    std::vector<std::uint8_t> valid;  // 1 where a surface is seen
    // 1 inside the scope's field-of-view mask (camera.mask; all 1 without
    // one): the pixels the colour frame shows. The mask output is valid and
    // inView.
    std::vector<std::uint8_t> inView;
    // 3 channels: the flow to the previous frame in pixels (du, dv: where the
    // pixel's surface point was, minus where it is), and 1 where that point
    // was visible in the previous frame (0: occluded, outside its view, no
    // surface here, or no previous frame). Filled by flowToPrevious.
    image::ImageF flow;
    // The centerline branch (index into the tree) the pixel sees; -1 where
    // no surface. Filled by labelBranches.
    std::vector<std::int32_t> branch;
};

// The ground truth of the pinhole camera `K` (no distortion: k1 = k2 = 0) at
// `cameraToWorld` on `mesh`, surfaces nearer than `nearMm` clipped (the
// renderer's near plane). Normals are the mesh's vertex normals interpolated
// (its geometric normal where it has none), turned to face the camera.
// Throws InputError for a lens with distortion or a mesh too large for exact
// face ids (more than 2^24 triangles), ResourceError when the buffers would
// not fit in memory.
GroundTruth groundTruth(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& cameraToWorld,
                        double nearMm, int threads = 0);

// The same through any lens (lens.hpp: a distorted pinhole, a fisheye, an
// omnidirectional lens), exact per pixel: each pixel centre's ray
// (unproject, double precision) is cast from the camera centre into the
// mesh (raycast.hpp: the first triangle it meets, watertight, in double
// precision), so every output is that triangle's at the ray's own hit.
//  - Near clipping, where the renderer clips (render::drawnInOneFace):
//    NearClip::CubeFaces, a hit counts from nearMm along the axis of the
//    cube-map face the ray falls in (t max(|x|, |y|, z) >= nearMm for the
//    unit ray); NearClip::Planar (the renderer's one wide face), from the
//    plane z = nearMm, the pinhole's near plane. For rays within 45 degrees
//    of the optical axis the two agree.
//  - Depth stays planar: the hit's z along the optical axis (not the ray's
//    length), as the pinhole's. A ray 90 degrees or more from the axis
//    (z <= 0: a fisheye wider than 180 degrees) has no planar depth: its
//    pixel is invalid (no depth, normal, uv or face) but in view.
//  - Pixels without a ray (beyond the lens's field) are invalid and outside
//    the field of view (inView 0); inView is 1 wherever a ray exists.
//  - Normals and uv as the pinhole's; face, b1, b2 the hit's (raycast.hpp's
//    Hit, raster::GBuffer's convention).
// The result is the same bytes for any thread count. The caster is built
// once per mesh and shared by the frames of a sequence; the form taking the
// mesh builds one per call (0.1 s for the phantom's 140k triangles). Throws
// InputError for a mesh of more than 2^24 triangles, ResourceError when the
// buffers would not fit in memory.
enum class NearClip { CubeFaces, Planar };
GroundTruth groundTruth(const RayCaster& caster, const Lens& lens, const frames::Mat4& cameraToWorld, double nearMm,
                        int threads = 0, NearClip clip = NearClip::CubeFaces);
GroundTruth groundTruth(const mesh::Mesh& mesh, const Lens& lens, const frames::Mat4& cameraToWorld, double nearMm,
                        int threads = 0, NearClip clip = NearClip::CubeFaces);

// Fills `current.flow`: each pixel's surface point projected into the
// previous frame's camera (exact: from the depth and the two poses, not
// estimated from the images). The point counts as visible there when it
// lands inside the previous frame and its field of view, in front of its
// near plane, and within 1 % + 0.01 mm of the previous frame's depth at that
// place (bilinear over the neighbours that see a surface); otherwise it is
// occluded. `previous` null (the first frame): no flow, nothing visible.
void flowToPrevious(GroundTruth& current, const frames::Intrinsics& K, const frames::Mat4& cameraToWorld,
                    const GroundTruth* previous, const frames::Mat4& previousCameraToWorld, double nearMm);
// The same through a lens: the pixel's point is its ray (unproject) scaled
// to the planar depth, X = ray z / ray_z, projected into the previous frame
// with project(); the visibility test is the pinhole's. For a pinhole lens
// (fromIntrinsics(K)) it is the form above to rounding (within 1e-6 px).
void flowToPrevious(GroundTruth& current, const Lens& lens, const frames::Mat4& cameraToWorld,
                    const GroundTruth* previous, const frames::Mat4& previousCameraToWorld, double nearMm);

// The branch of each vertex: the one whose centerline passes nearest, in
// units of its lumen radius there (so a thin branch beside a thick one gets
// its own wall). Throws InputError for a tree without branches.
std::vector<std::int32_t> vertexBranches(const mesh::Mesh& mesh, const mesh::Centerline& tree);
// Fills `truth.branch`: the branch of the seen triangle's nearest vertex
// (the largest barycentric).
void labelBranches(GroundTruth& truth, const mesh::Mesh& mesh, const std::vector<std::int32_t>& vertexBranch);

// The pixels inside the field-of-view mask of a frame (camera.mask and
// camera.mask_radius, the shader's own test at the pixel centre), 1 inside.
std::vector<std::uint8_t> fieldOfView(const shading::FrameSetup& frame);

// Where a frame's outputs go: out.png, frame 12 -> out_0012.png,
// out_0012.depth.exr, out_0012.depth.png, out_0012.normals.exr, ...
// `rgbName` is the colour frame's name (its stem names the others).
std::vector<std::filesystem::path> outputFiles(const std::filesystem::path& rgbName, const Outputs& outputs);

// Depth in the 16-bit PNG: value = round(depth / depthPngScaleMm), 0 where
// no surface, 65535 at and beyond 65535 x scale.
inline constexpr double kDefaultDepthPngScaleMm = 0.01;

// Writes the ground-truth files of `outputs` next to `rgbName` (each
// atomically: a file that exists is whole).
void writeGroundTruth(const GroundTruth& truth, const std::filesystem::path& rgbName, const Outputs& outputs,
                      double depthPngScaleMm = kDefaultDepthPngScaleMm);

// The manifest's "outputs" block: per output its file pattern (relative to
// the manifest, e.g. "fly_{frame:04}.depth.exr"), encoding, channels, unit
// and convention, so a user needs no other document to read the files.
// `tree`: the centerline whose branches the branch output labels (its label
// table goes into the block).
nlohmann::json describeOutputs(const std::filesystem::path& output, int frames, const Outputs& outputs,
                               double depthPngScaleMm = kDefaultDepthPngScaleMm,
                               const mesh::Centerline* tree = nullptr);

}  // namespace mucosa::dataset
