#pragma once
// PNG input (libpng) and output (Mucosa's own parallel encoder on zlib; see
// docs/theory.md "PNG output" for why).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include <mucosa/image/image.hpp>

namespace mucosa::image {

enum class PngCompression {
    // Per 1 MiB piece, from a probe of its filtered bytes: Huffman-only
    // DEFLATE where they look like noise (normal maps), zlib's run-length
    // strategy where it does as well as LZ77 (filtered photographs), zlib at
    // `level` otherwise (depth-like data, where longer matches pay). See
    // docs/dependencies.md.
    Auto,
    Zlib,  // zlib at `level` everywhere (what libpng would write, in parallel)
};

struct PngWriteOptions {
    PngCompression compression = PngCompression::Auto;
    int level = 6;    // zlib level 0..9 for the zlib pieces
    int threads = 0;  // compression threads; 0 = all hardware threads. Bytes don't depend on it.
};

// Encodes 8- or 16-bit grey (1), grey+alpha (2), RGB (3) or RGBA (4) images.
std::vector<std::byte> encodePng(const Image8& img, const PngWriteOptions& opt = {});
std::vector<std::byte> encodePng(const Image16& img, const PngWriteOptions& opt = {});

// Rows produced on demand, so an image never has to exist whole in memory
// (`mucosa map` streams normals -> filter -> deflate in bands of rows).
// `row(y, dst)` writes row y as PNG stores it: width * channels samples, 16-bit
// ones big-endian; it is called from several threads at once, possibly more
// than once per row, and must always give the same bytes.
struct PngRowSource {
    int width = 0, height = 0;
    int channels = 3;  // 1..4 as above
    int bitDepth = 8;  // 8 or 16
    std::function<void(int y, std::uint8_t* dst)> row;
};
std::vector<std::byte> encodePng(const PngRowSource& rows, const PngWriteOptions& opt = {});

// Atomic: a temporary next to `path`, renamed when complete.
void writePng(const std::filesystem::path& path, const Image8& img, const PngWriteOptions& opt = {});
void writePng(const std::filesystem::path& path, const Image16& img, const PngWriteOptions& opt = {});

// A decoded PNG: samples widened to 16 bits but keeping their bit depth
// (8-bit files hold 0..255). Palette is expanded to RGB(A); low bit depths to 8.
struct PngImage {
    int bitDepth = 8;  // 8 or 16
    Image16 pixels;
};

// Throws IoError/InputError naming the file when it is missing or not a PNG.
PngImage readPng(const std::filesystem::path& path);
PngImage decodePng(const std::vector<std::byte>& bytes, const std::string& nameForErrors = "<memory>");

Image8 to8(const PngImage& png);  // 16-bit values rounded to 8

// What a PNG's header (its IHDR chunk, the first 33 bytes) says, without
// decoding the image: for checking a folder of frames before the long work.
// Throws IoError when the file cannot be read and InputError when it is not
// a PNG.
struct PngHeader {
    int width = 0, height = 0;
    int bitDepth = 8;
    int colorType = 0;  // PNG's: 0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA
};
PngHeader readPngHeader(const std::filesystem::path& path);

}  // namespace mucosa::image
