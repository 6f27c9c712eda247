#include <mucosa/image/png.hpp>

#include <png.h>

#include <algorithm>
#include <array>
#include <csetjmp>
#include <cstring>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::image {

namespace {

struct Reader {
    const std::byte* data;
    std::size_t size, at;
};

struct ErrorState {
    std::string message;
};

void onRead(png_structp png, png_bytep out, png_size_t n) {
    auto* r = static_cast<Reader*>(png_get_io_ptr(png));
    if (r->at + n > r->size) png_error(png, "file is truncated");
    std::memcpy(out, r->data + r->at, n);
    r->at += n;
}

void onError(png_structp png, png_const_charp msg) {
    auto* st = static_cast<ErrorState*>(png_get_error_ptr(png));
    st->message = msg;
    png_longjmp(png, 1);
}

void onWarning(png_structp, png_const_charp) {}

std::uint32_t be32(const std::byte* p) {
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

// Deflate's best case is 1032:1 (a 258-byte match coded in 2 bits, RFC 1951);
// zlib adds a 2-byte header and 4-byte Adler-32 that only lower the ratio.
constexpr std::uint64_t kDeflateMaxRatio = 1032;

// Walks the chunk list (PNG spec, 5.3) before libpng allocates anything and
// refuses an image whose declared size cannot come out of the IDAT bytes that
// are actually present: the filtered scanlines hold at least w*h*bitsPerPixel/8
// bytes (interlaced or not), and n compressed bytes inflate to at most
// 1032*n. Chunks past the end of the buffer count only what is there.
void checkDeclaredSizeAgainstData(const std::vector<std::byte>& bytes, const std::string& name) {
    std::size_t at = 8;
    std::uint64_t idat = 0, w = 0, h = 0, bitsPerPixel = 0;
    bool header = false;
    while (at + 8 <= bytes.size()) {
        const std::uint64_t len = be32(bytes.data() + at);
        const std::byte* type = bytes.data() + at + 4;
        const std::size_t dataAt = at + 8;
        const std::uint64_t present = std::min<std::uint64_t>(len, bytes.size() - dataAt);
        if (std::memcmp(type, "IHDR", 4) == 0 && present >= 13) {
            const std::byte* d = bytes.data() + dataAt;
            w = be32(d);
            h = be32(d + 4);
            const unsigned depth = unsigned(d[8]), colorType = unsigned(d[9]);
            const unsigned samples = colorType == 2 ? 3 : colorType == 4 ? 2 : colorType == 6 ? 4 : 1;
            bitsPerPixel = std::uint64_t(depth) * samples;
            header = true;
        } else if (std::memcmp(type, "IDAT", 4) == 0) {
            idat += present;
        } else if (std::memcmp(type, "IEND", 4) == 0) {
            break;
        }
        if (len > bytes.size() - dataAt) break;
        at = dataAt + len + 4;  // data + CRC
    }
    if (!header) return;  // libpng reports the missing IHDR itself
    const std::uint64_t rawBytes = saturatingMul(saturatingMul(w, h), bitsPerPixel) / 8;
    const std::uint64_t canInflateTo = saturatingMul(idat + 1, kDeflateMaxRatio);
    if (rawBytes > canInflateTo)
        throw InputError("PNG", name,
                         fmt::format("{}x{} image needs at least {} bytes of pixel data but its {} compressed bytes "
                                     "can hold at most {} (deflate's 1032:1 limit)",
                                     w, h, rawBytes, idat, canInflateTo));
}

}  // namespace

PngImage decodePng(const std::vector<std::byte>& bytes, const std::string& name) {
    if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
        throw InputError("PNG", name, "not a PNG file (bad signature)");
    checkDeclaredSizeAgainstData(bytes, name);
    ErrorState st;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st, onError, onWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw InternalError("libpng: out of memory");
    }
    Reader reader{bytes.data(), bytes.size(), 0};
    PngImage result;
    // Everything that can longjmp lives between setjmp and the destroy; no
    // object with a destructor is created in between.
    std::uint64_t need = 0;
    png_uint_32 w = 0, h = 0;
    int depth = 0, channels = 0;
    std::vector<png_bytep> rows;
    std::vector<std::uint8_t> buffer;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw InputError("PNG", name, st.message.empty() ? "corrupt data" : st.message);
    }
    png_set_read_fn(png, &reader, onRead);
    png_set_user_limits(png, 1u << 20, 1u << 20);
    png_read_info(png, info);
    const int colorType = png_get_color_type(png, info);
    if (colorType == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (png_get_bit_depth(png, info) < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    png_read_update_info(png, info);
    w = png_get_image_width(png, info);
    h = png_get_image_height(png, info);
    depth = png_get_bit_depth(png, info);
    channels = png_get_channels(png, info);
    need = imageBytes(static_cast<int>(w), static_cast<int>(h), channels, 2 + depth / 8);
    if (need > availableMemoryBytes()) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw ResourceError("PNG", name, fmt::format("{}x{} image needs {} bytes, more than available", w, h, need));
    }
    buffer.resize(static_cast<std::size_t>(png_get_rowbytes(png, info)) * h);
    rows.resize(h);
    for (png_uint_32 y = 0; y < h; ++y) rows[y] = buffer.data() + y * png_get_rowbytes(png, info);
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);

    result.bitDepth = depth;
    result.pixels = Image16(static_cast<int>(w), static_cast<int>(h), channels);
    const std::size_t n = result.pixels.size();
    std::uint16_t* dst = result.pixels.data();
    if (depth == 16) {
        for (std::size_t i = 0; i < n; ++i)
            dst[i] = static_cast<std::uint16_t>((buffer[2 * i] << 8) | buffer[2 * i + 1]);
    } else {
        for (std::size_t i = 0; i < n; ++i) dst[i] = buffer[i];
    }
    return result;
}

PngHeader readPngHeader(const std::filesystem::path& path) {
    const std::string name = path.string();
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("image", name, "cannot be opened");
    std::array<std::byte, 33> b{};
    in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
    static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (in.gcount() < static_cast<std::streamsize>(b.size()) || std::memcmp(b.data(), kSignature, 8) != 0 ||
        be32(b.data() + 8) != 13 || std::memcmp(b.data() + 12, "IHDR", 4) != 0)
        throw InputError("image", name, "is not a PNG (no PNG signature and header)");
    PngHeader h;
    const std::uint32_t w = be32(b.data() + 16), hh = be32(b.data() + 20);
    if (w == 0 || hh == 0 || w > 0x7fffffffu || hh > 0x7fffffffu)
        throw InputError("image", name, fmt::format("declares a {}x{} image", w, hh));
    h.width = static_cast<int>(w);
    h.height = static_cast<int>(hh);
    h.bitDepth = static_cast<int>(b[24]);
    h.colorType = static_cast<int>(b[25]);
    return h;
}

PngImage readPng(const std::filesystem::path& path) {
    return decodePng(readFile(path), path.string());
}

Image8 to8(const PngImage& png) {
    const Image16& src = png.pixels;
    Image8 out(src.width(), src.height(), src.channels());
    for (std::size_t i = 0; i < src.size(); ++i)
        out.data()[i] = png.bitDepth == 16 ? static_cast<std::uint8_t>((src.data()[i] * 255u + 32767u) / 65535u)
                                           : static_cast<std::uint8_t>(src.data()[i]);
    return out;
}

}  // namespace mucosa::image
