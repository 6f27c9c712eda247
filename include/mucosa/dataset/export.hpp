#pragma once
// Exporters of a frames file (frames::FrameSet: the dataset manifest `mucosa fit`
// reads) to other tools: a TUM RGB-D trajectory, a COLMAP text model and a
// nerfstudio transforms.json (docs/datasets.md, "Exporting to other tools").
//
// Mucosa's conventions: OpenCV camera axes (x right, y down, z forward),
// the top-left pixel's centre at (0, 0), row-major camera_to_world in mm.
// Each exporter converts to its format's own once, in export.cpp, which
// cites where each convention is documented.
//
// Every exporter first builds its files in memory (buildExport), checking
// every frame, so bad input is refused with an InputError before anything is
// written; writeExport then writes each file to a temporary name and renames
// them all at the end.
#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <mucosa/dataset/lens.hpp>
#include <mucosa/frames/frames.hpp>

namespace mucosa::dataset {

enum class ExportFormat { Tum, Colmap, Nerfstudio };

// "tum", "colmap", "nerfstudio".
const char* exportFormatName(ExportFormat format) noexcept;
// Throws InputError(field, file, "unknown format 'x' (known: tum, colmap, nerfstudio)").
ExportFormat parseExportFormat(std::string_view name, const std::string& field = "format",
                               const std::string& file = "");

struct ExportOptions {
    // TUM timestamps: frame i of the frames file at i / fps seconds.
    double fps = 30.0;
    // Output length units per millimetre. Unset: the format's own unit, TUM
    // metres (0.001, the unit its benchmark tools assume), COLMAP and
    // nerfstudio millimetres (1: both are scale-free; the value is recorded
    // in the files).
    std::optional<double> scale;
    // The frames file: named in errors and recorded in the outputs.
    std::filesystem::path source;
    // COLMAP's image NAMEs are relative to this folder (the frames file's,
    // so COLMAP's --image_path is that folder). Empty: the current folder.
    std::filesystem::path imageRoot;
    // The frames file's "lens" (mucosa render --lens), when it has one: a
    // fisheye is exported as OPENCV_FISHEYE with its k1..k4 (the frames'
    // intrinsics give fx, fy, cx, cy); an omnidirectional lens only as the
    // TUM trajectory (COLMAP and nerfstudio have no such model).
    std::optional<Lens> lens;
};

// The default scale of a format (see ExportOptions::scale).
double defaultScale(ExportFormat format) noexcept;
// "mm", "cm", "m" for 1, 0.1, 0.001; otherwise "<scale> x mm".
std::string unitName(double scale);

struct ExportFile {
    std::filesystem::path path;
    std::string text;
};

struct Export {
    ExportFormat format = ExportFormat::Tum;
    std::vector<ExportFile> files;  // written by writeExport, in this order
    std::filesystem::path folder;   // COLMAP: the model folder (writeExport creates it); else empty
    std::size_t frames = 0;         // frames exported
    std::size_t skipped = 0;        // frames `mucosa register` flagged as not converged: not exported
    std::size_t cameras = 0;        // distinct intrinsics
    double scale = 1.0;             // output units per mm
};

// The files of `format` for `set`, in memory. `out` is the output: the TUM
// trajectory file, the COLMAP model folder (cameras.txt, images.txt,
// points3D.txt), or the nerfstudio transforms.json (or an existing folder to
// put transforms.json in). Frames flagged as not converged are left out (their
// pose is wrong), as `mucosa fit` does. Throws InputError naming
// options.source and the field for an empty frame set, every frame flagged,
// a camera_to_world that is not rigid (orthonormal rotation with det +1 within
// the tolerance readFrames allows, last row 0 0 0 1, finite), unusable
// intrinsics, a non-positive fps or scale, or what a format cannot hold.
Export buildExport(const frames::FrameSet& set, ExportFormat format, const std::filesystem::path& out,
                   const ExportOptions& options = {});

// Writes every file of `e` to a temporary name beside it, then renames them
// all; creates the COLMAP folder if its parent exists. Throws IoError.
void writeExport(const Export& e);

// buildExport then writeExport.
Export exportFrames(const frames::FrameSet& set, ExportFormat format, const std::filesystem::path& out,
                    const ExportOptions& options = {});

// A unit quaternion, Hamilton convention (i j = k), as COLMAP, TUM and Eigen
// use it.
struct Quaternion {
    double w = 1, x = 0, y = 0, z = 0;
};

// The rotation of camera_to_world's upper-left 3x3, with w >= 0 (Shepperd
// 1978). For a matrix that is a rotation only to within readFrames'
// tolerance, the quaternion of a nearby rotation.
Quaternion quaternionFromRotation(const frames::Mat4& m) noexcept;
// The rotation matrix of a unit quaternion, in a Mat4 with no translation.
frames::Mat4 rotationFromQuaternion(const Quaternion& q) noexcept;

// The lens models the exporters know, one case each: a frame's intrinsics
// (a pinhole with Brown radial k1, k2), or the frames file's fisheye lens
// (Kannala-Brandt k1..k4: COLMAP's and nerfstudio's OPENCV_FISHEYE).
enum class ExportLens { Pinhole, BrownRadial, Fisheye };
ExportLens lensOf(const frames::Intrinsics& K, const Lens* lens = nullptr) noexcept;

}  // namespace mucosa::dataset
