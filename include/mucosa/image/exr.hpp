#pragma once
// OpenEXR float images (for height fields and other linear data).
#include <filesystem>
#include <string>

#include <mucosa/image/image.hpp>

namespace mucosa::image {

// OpenEXR's lossless compressions for FLOAT pixels (the lossy ones, PXR24,
// B44, DWA, would change ground truth). ZIP (zlib over 16 scanlines) is
// OpenEXR's default and the smallest on smooth data; None writes the floats
// as they are, the fastest; RLE only packs runs (masks, the background);
// PIZ (wavelet + Huffman) is the best on noisy data.
enum class ExrCompression { None, Rle, Zips, Zip, Piz };
// "none", "rle", "zips", "zip", "piz" (OpenEXR's names, lower case).
const char* exrCompressionName(ExrCompression c) noexcept;
// Throws InputError naming `what` and `where` for another name.
ExrCompression parseExrCompression(const std::string& name, const std::string& what, const std::string& where);

// Writes 1 channel as "Y", 3 as "R","G","B", 4 as RGBA; FLOAT pixels. Atomic.
void writeExr(const std::filesystem::path& path, const ImageF& img, ExrCompression compression = ExrCompression::Zip);
ImageF readExr(const std::filesystem::path& path);

}  // namespace mucosa::image
