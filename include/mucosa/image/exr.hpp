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

// OpenEXR compresses a file's blocks of scan lines on a process-wide thread
// pool, which writeExr sizes to the machine the first time unless the program
// has chosen first. A program that writes many files at once, each on a task
// of its own (`mucosa render --outputs`), sets 0: the files already fill the
// cores, and the pool would only add a hand-off (a task and two semaphore
// posts) per block of scan lines, one per line when uncompressed. Call it
// before writing, not while another thread writes.
void setExrThreads(int threads);

}  // namespace mucosa::image
