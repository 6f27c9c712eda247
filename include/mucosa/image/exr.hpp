#pragma once
// OpenEXR float images (for height fields and other linear data).
#include <filesystem>

#include <mucosa/image/image.hpp>

namespace mucosa::image {

// Writes 1 channel as "Y", 3 as "R","G","B", 4 as RGBA; FLOAT pixels, ZIP
// compression. Atomic.
void writeExr(const std::filesystem::path& path, const ImageF& img);
ImageF readExr(const std::filesystem::path& path);

}  // namespace mucosa::image
