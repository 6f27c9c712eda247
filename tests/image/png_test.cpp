#include <mucosa/image/png.hpp>

#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "image/deflate_huffman.hpp"
#include "test_support.hpp"

using namespace mucosa;
using namespace mucosa::image;

namespace {

// Decodes with libpng's simplified API: an independent decoder for our encoder.
template <class T>
Image<T> decodeWithLibpng(const std::vector<std::byte>& bytes, int channels) {
    png_image img{};
    img.version = PNG_IMAGE_VERSION;
    EXPECT_TRUE(png_image_begin_read_from_memory(&img, bytes.data(), bytes.size())) << img.message;
    static const png_uint_32 formats8[5] = {0, PNG_FORMAT_GRAY, PNG_FORMAT_GA, PNG_FORMAT_RGB, PNG_FORMAT_RGBA};
    img.format = formats8[channels];
    if (sizeof(T) == 2) img.format |= PNG_FORMAT_FLAG_LINEAR;
    Image<T> out(static_cast<int>(img.width), static_cast<int>(img.height), channels);
    if (sizeof(T) == 2) {
        // The simplified API converts 16-bit data to linear with gamma; read the
        // raw samples with our decoder instead and use libpng only for 8-bit.
        png_image_free(&img);
        PngImage p = decodePng(bytes);
        for (std::size_t i = 0; i < out.size(); ++i) out.data()[i] = static_cast<T>(p.pixels.data()[i]);
        return out;
    }
    EXPECT_TRUE(png_image_finish_read(&img, nullptr, out.data(), 0, nullptr)) << img.message;
    return out;
}

template <class T>
Image<T> noiseImage(int w, int h, int c, unsigned seed) {
    Image<T> img(w, h, c);
    std::mt19937 rng(seed);
    for (std::size_t i = 0; i < img.size(); ++i) img.data()[i] = static_cast<T>(rng());
    return img;
}

template <class T>
Image<T> smoothImage(int w, int h, int c) {
    Image<T> img(w, h, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k)
                img.at(x, y, k) = static_cast<T>((x / 7 + y / 5 + k * 40) * (sizeof(T) == 2 ? 97 : 1));
    return img;
}

}  // namespace

TEST(Png, RoundTripsEveryChannelCountAndDepth) {
    for (int c = 1; c <= 4; ++c) {
        for (auto [w, h] : {std::pair{1, 1}, std::pair{3, 2}, std::pair{97, 61}}) {
            for (PngCompression mode : {PngCompression::Auto, PngCompression::Zlib}) {
                PngWriteOptions opt;
                opt.compression = mode;
                const Image8 a = noiseImage<std::uint8_t>(w, h, c, 1);
                EXPECT_EQ(decodeWithLibpng<std::uint8_t>(encodePng(a, opt), c), a) << c << " " << w;
                const Image16 b = noiseImage<std::uint16_t>(w, h, c, 2);
                const PngImage d = decodePng(encodePng(b, opt));
                EXPECT_EQ(d.bitDepth, 16);
                EXPECT_EQ(d.pixels, b);
            }
        }
    }
}

TEST(Png, MultiPieceStreamsDecodeForNoiseAndSmoothContent) {
    // > 1 MiB of filtered data: several pieces, joined by sync flushes; noise
    // takes the Huffman-only path, smooth content the zlib path.
    const Image8 noise = noiseImage<std::uint8_t>(1024, 700, 3, 3);
    const Image8 smooth = smoothImage<std::uint8_t>(1024, 700, 3);
    const Image16 smooth16 = smoothImage<std::uint16_t>(600, 500, 3);
    EXPECT_EQ(decodeWithLibpng<std::uint8_t>(encodePng(noise), 3), noise);
    EXPECT_EQ(decodeWithLibpng<std::uint8_t>(encodePng(smooth), 3), smooth);
    EXPECT_EQ(decodePng(encodePng(smooth16)).pixels, smooth16);
    // Smooth content must still compress well (the zlib path was chosen).
    EXPECT_LT(encodePng(smooth).size(), smooth.size() / 20);
}

TEST(Png, MasksLabelsAndPhotographsAreNoLargerThanZlibsOwn) {
    // Near-constant data (a mask, a label image) has under 1 bit a byte of
    // entropy, below any Huffman code's floor: the probe must not pick
    // Huffman-only for it (it did, at 1 bit a byte: 20-40x zlib's size).
    // Filtered photographs take the run-length strategy, no larger than
    // zlib level 6.
    Image8 mask(640, 480, 1);
    Image16 labels(640, 480, 1);
    Image8 photo(640, 480, 3);
    std::mt19937 rng(5);
    std::normal_distribution<double> grain(0.0, 1.5);
    for (int y = 0; y < 480; ++y)
        for (int x = 0; x < 640; ++x) {
            const double r = std::hypot(x - 320.0, y - 240.0);
            mask.at(x, y) = r < 200 ? 255 : 0;
            labels.at(x, y) = static_cast<std::uint16_t>(r < 90 ? 0 : (x < 320 ? 3 : 7));
            for (int c = 0; c < 3; ++c)
                photo.at(x, y, c) =
                    static_cast<std::uint8_t>(std::clamp(120 + 80 * std::cos(r / 60.0 + c) + grain(rng), 0.0, 255.0));
        }
    PngWriteOptions zlib6;
    zlib6.compression = PngCompression::Zlib;
    EXPECT_LE(encodePng(mask).size(), encodePng(mask, zlib6).size() * 3 / 2);
    EXPECT_LE(encodePng(labels).size(), encodePng(labels, zlib6).size() * 3 / 2);
    EXPECT_LT(encodePng(mask).size(), mask.size() / 50);
    EXPECT_LE(encodePng(photo).size(), encodePng(photo, zlib6).size() * 105 / 100);
    EXPECT_EQ(decodeWithLibpng<std::uint8_t>(encodePng(photo), 3), photo);
    EXPECT_EQ(decodePng(encodePng(labels)).pixels, labels);
}

TEST(Png, BytesAreIdenticalForAnyThreadCount) {
    const Image8 img = noiseImage<std::uint8_t>(800, 900, 3, 4);
    PngWriteOptions one;
    one.threads = 1;
    const auto ref = encodePng(img, one);
    for (int t : {2, 3, 8}) {
        PngWriteOptions o;
        o.threads = t;
        EXPECT_EQ(encodePng(img, o), ref) << t;
    }
}

TEST(Png, HuffmanCodeLengthsAreLimitedAndComplete) {
    // Fibonacci frequencies force a deep tree; lengths must stay <= 15 and
    // satisfy Kraft's equality (a complete prefix code).
    std::vector<std::uint32_t> freq(40);
    std::uint32_t a = 1, b = 1;
    for (auto& f : freq) {
        f = a;
        const std::uint32_t c = a + b;
        a = b;
        b = c;
        if (b > 1u << 30) b = 1u << 30;
    }
    const auto len = image::detail::huffmanLengths(freq, 15);
    double kraft = 0;
    for (auto l : len) {
        ASSERT_GE(l, 1);
        ASSERT_LE(l, 15);
        kraft += std::ldexp(1.0, -l);
    }
    EXPECT_DOUBLE_EQ(kraft, 1.0);
}

TEST(Png, RejectsFilesThatAreNotPng) {
    test::TempDir dir;
    EXPECT_THROW(readPng(dir / "missing.png"), IoError);
    writeFileAtomic(dir / "text.png", std::string("hello, not a png"));
    EXPECT_THROW(readPng(dir / "text.png"), InputError);
    auto bytes = encodePng(noiseImage<std::uint8_t>(64, 64, 3, 5));
    bytes.resize(bytes.size() / 2);
    EXPECT_THROW(decodePng(bytes), InputError);
}

// The header alone gives the size, depth and colour type the full decode
// gives; a file that is not a PNG, a short one or a missing one is refused.
TEST(Png, HeaderReadsWhatTheDecodeFinds) {
    test::TempDir dir;
    writePng(dir / "rgb.png", noiseImage<std::uint8_t>(37, 21, 3, 1));
    writePng(dir / "grey16.png", noiseImage<std::uint16_t>(5, 64, 1, 2));
    for (const char* name : {"rgb.png", "grey16.png"}) {
        const PngHeader h = readPngHeader(dir / name);
        const PngImage full = readPng(dir / name);
        EXPECT_EQ(h.width, full.pixels.width()) << name;
        EXPECT_EQ(h.height, full.pixels.height()) << name;
        EXPECT_EQ(h.bitDepth, full.bitDepth) << name;
    }
    EXPECT_EQ(readPngHeader(dir / "rgb.png").colorType, 2);
    EXPECT_EQ(readPngHeader(dir / "grey16.png").colorType, 0);
    EXPECT_THROW(readPngHeader(dir / "missing.png"), IoError);
    writeFileAtomic(dir / "text.png", std::string("hello, not a png, but long enough to hold a header"));
    EXPECT_THROW(readPngHeader(dir / "text.png"), InputError);
    auto bytes = encodePng(noiseImage<std::uint8_t>(8, 8, 3, 5));
    bytes.resize(20);  // cut inside the IHDR chunk
    writeFileAtomic(dir / "short.png", std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    EXPECT_THROW(readPngHeader(dir / "short.png"), InputError);
}

TEST(Png, WritesAtomicallyAndLeavesNoTemporaryOnError) {
    test::TempDir dir;
    const Image8 img = noiseImage<std::uint8_t>(16, 16, 3, 6);
    writePng(dir / "a.png", img);
    EXPECT_EQ(readPng(dir / "a.png").pixels.size(), img.size());
    EXPECT_THROW(writePng(dir / "no-such-dir" / "a.png", img), IoError);
    int entries = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
        (void)e;
        ++entries;
    }
    EXPECT_EQ(entries, 1);
}

namespace {

void appendChunk(std::vector<std::byte>& out, const char* type, const std::vector<std::uint8_t>& data) {
    auto put32 = [&](std::uint32_t v) {
        for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::byte>((v >> s) & 0xff));
    };
    put32(static_cast<std::uint32_t>(data.size()));
    std::vector<std::uint8_t> typed(type, type + 4);
    typed.insert(typed.end(), data.begin(), data.end());
    for (std::uint8_t b : typed) out.push_back(static_cast<std::byte>(b));
    put32(static_cast<std::uint32_t>(crc32(0, typed.data(), static_cast<uInt>(typed.size()))));
}

}  // namespace

// A 69-byte PNG claiming 30000x30000 RGBA took 4.0 GB and 6.6 s
// before libpng said "Not enough image data". 24 compressed bytes can inflate
// to at most 24*1032 bytes, far from the 3.6 GB the header declares.
TEST(Png, RefusesADeclaredSizeItsCompressedDataCannotHold) {
    std::vector<std::byte> bytes;
    for (int b : std::initializer_list<int>{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'})
        bytes.push_back(static_cast<std::byte>(b));
    appendChunk(bytes, "IHDR", {0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30, 8, 6, 0, 0, 0});
    appendChunk(bytes, "IDAT", std::vector<std::uint8_t>(24, 0x78));
    ASSERT_EQ(bytes.size(), 69u);
    try {
        decodePng(bytes, "hostile.png");
        FAIL() << "accepted a 30000x30000 image from 24 compressed bytes";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("hostile.png"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("1032"), std::string::npos) << e.what();
    }
}

// The bound must not refuse what deflate really achieves: a constant 4096x4096
// image from our encoder compresses close to the 1032:1 limit and still loads.
TEST(Png, HighlyCompressedLegitimateImagesStillLoad) {
    Image8 img(4096, 4096, 1);
    std::fill(img.data(), img.data() + img.size(), std::uint8_t{77});
    const auto bytes = encodePng(img);
    const PngImage back = decodePng(bytes, "constant.png");
    ASSERT_EQ(back.pixels.width(), 4096);
    ASSERT_EQ(back.pixels.height(), 4096);
    EXPECT_EQ(back.pixels.data()[4096 * 4096 - 1], 77);
}
