#include <mucosa/image/png.hpp>

#include <png.h>

#include <csetjmp>
#include <cstring>
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

}  // namespace

PngImage decodePng(const std::vector<std::byte>& bytes, const std::string& name) {
    if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
        throw InputError("PNG", name, "not a PNG file (bad signature)");
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
