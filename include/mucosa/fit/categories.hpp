#pragma once
// The user study's five image categories for every registered frame (the
// paper's Fig. 5), rendered at the frame's own pose and intrinsics:
//   1 unreal:            per-vertex Phong, flat colour, no texture, no fitted shading;
//   2 BRDF, low-res:     the fitted shading x the atlas reduced 8x (blurry texture);
//   3 BRDF:              the fitted shading x the full atlas (mode `brdf`);
//   4 BRDF + specular:   3 plus the method's noise-based highlights (mode `brdf-noise`);
//   5 real:              the frame itself.
// Writes the images and a manifest (images.json) the study kit reads.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/brdf.hpp>

namespace mucosa::fit {

// What `mucosa fit` wrote, read back: brdf.json + texture.png.
struct FittedModel {
    shading::BrdfParams brdf;
    image::ImageF texture;  // linear albedo, 3 channels
    std::array<float, 2> uvMin{0, 0}, uvMax{1, 1};
};
FittedModel readFitDirectory(const std::filesystem::path& dir);

struct CategoriesOptions {
    std::string patient = "patient";
    int lowResDivisor = 8;             // category 2: the atlas reduced by this factor
    std::string preset = "bronchial";  // reflectance map of category 4
    double mapTiling = 4.0;
    std::function<void(int done, int total)> progress;
    int threads = 0;
};

struct CategoryImage {
    std::string id;
    std::filesystem::path file;  // relative to the output folder
    int category = 0;
    int pose = 0;
};

// Renders into `outDir` (created): pose<NNN>_cat<C>.png for C = 1..5 and
// images.json. Throws InputError for frames that cannot be rendered.
std::vector<CategoryImage> renderCategories(mesh::Mesh mesh, const frames::FrameSet& frames, const FittedModel& model,
                                            const std::filesystem::path& outDir, const CategoriesOptions& options);

}  // namespace mucosa::fit
