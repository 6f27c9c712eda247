#include <mucosa/image/exr.hpp>

#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include <ImfRgbaFile.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "test_support.hpp"

using namespace mucosa;
using namespace mucosa::image;

TEST(Exr, FloatImagesRoundTripExactly) {
    test::TempDir dir;
    for (int c : {1, 3, 4}) {
        ImageF img(37, 23, c);
        for (std::size_t i = 0; i < img.size(); ++i) img.data()[i] = static_cast<float>(i) * 0.001f - 0.3f;
        writeExr(dir / "h.exr", img);
        EXPECT_EQ(readExr(dir / "h.exr"), img) << c;
    }
}

TEST(Exr, EveryLosslessCompressionRoundTripsBitForBitAndIsNamedInTheFile) {
    test::TempDir dir;
    // Noisy data with the values ground truth holds: zeros (no hit), negative
    // normals, denormals, the largest floats and an infinity.
    ImageF img(61, 40, 3);
    std::uint32_t state = 12345u;
    for (std::size_t i = 0; i < img.size(); ++i) {
        state = state * 1664525u + 1013904223u;
        img.data()[i] = (i % 7 == 0) ? 0.0f : static_cast<float>(state >> 8) * 1e-4f - 500.0f;
    }
    img.data()[5] = 1e-40f;
    img.data()[6] = -3.4e38f;
    img.data()[8] = std::numeric_limits<float>::infinity();
    const std::pair<ExrCompression, Imf::Compression> cases[] = {{ExrCompression::None, Imf::NO_COMPRESSION},
                                                                 {ExrCompression::Rle, Imf::RLE_COMPRESSION},
                                                                 {ExrCompression::Zips, Imf::ZIPS_COMPRESSION},
                                                                 {ExrCompression::Zip, Imf::ZIP_COMPRESSION},
                                                                 {ExrCompression::Piz, Imf::PIZ_COMPRESSION}};
    std::uintmax_t noneSize = 0;
    for (const auto& [c, imf] : cases) {
        const std::string name = exrCompressionName(c);
        EXPECT_EQ(parseExrCompression(name, "--exr-compression", "cli"), c);
        const auto file = dir / (name + ".exr");
        writeExr(file, img, c);
        const ImageF back = readExr(file);
        ASSERT_EQ(back.size(), img.size()) << name;
        EXPECT_EQ(std::memcmp(back.data(), img.data(), img.size() * sizeof(float)), 0) << name;
        EXPECT_EQ(Imf::RgbaInputFile(file.c_str()).header().compression(), imf) << name;
        if (c == ExrCompression::None) noneSize = std::filesystem::file_size(file);
    }
    // Uncompressed is the floats themselves plus a header and line offsets.
    EXPECT_GE(noneSize, img.size() * sizeof(float));
    EXPECT_LE(noneSize, img.size() * sizeof(float) + 2000);
    // Smooth data (a depth ramp) is what zip is the default for.
    ImageF ramp(128, 128, 1);
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) ramp.at(x, y) = 10.0f + 0.25f * static_cast<float>(y);
    writeExr(dir / "ramp_none.exr", ramp, ExrCompression::None);
    writeExr(dir / "ramp_zip.exr", ramp);
    EXPECT_LT(std::filesystem::file_size(dir / "ramp_zip.exr") * 10, std::filesystem::file_size(dir / "ramp_none.exr"));
    for (const char* bad : {"ZIP", "b44", "dwaa", "pxr24", ""})
        EXPECT_THROW(parseExrCompression(bad, "--exr-compression", "cli"), InputError) << bad;
}

TEST(Exr, MissingOrCorruptFileIsAnInputError) {
    test::TempDir dir;
    EXPECT_THROW(readExr(dir / "none.exr"), IoError);
    writeFileAtomic(dir / "bad.exr", std::string("not an exr"));
    EXPECT_THROW(readExr(dir / "bad.exr"), InputError);
}

namespace {

// A scanline EXR header (OpenEXR file layout) with the given data window and
// compression, padded with zeros to `total` bytes.
std::string hostileExr(std::int32_t x1, std::int32_t y1, std::uint8_t compression, std::size_t total) {
    std::string s;
    auto u32 = [&](std::uint32_t v) {
        for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
    };
    auto attr = [&](const char* name, const char* type, const std::string& value) {
        s += name;
        s.push_back('\0');
        s += type;
        s.push_back('\0');
        u32(static_cast<std::uint32_t>(value.size()));
        s += value;
    };
    auto box = [&](std::int32_t a, std::int32_t b) {
        std::string v;
        for (std::int32_t x : {0, 0, a, b})
            for (int i = 0; i < 4; ++i)
                v.push_back(static_cast<char>((static_cast<std::uint32_t>(x) >> (8 * i)) & 0xff));
        return v;
    };
    u32(20000630u);
    u32(2);
    std::string ch = std::string("R\0", 2) + std::string("\x01\0\0\0", 4) + std::string(4, '\0') +
                     std::string("\x01\0\0\0\x01\0\0\0", 8) + std::string(1, '\0');
    attr("channels", "chlist", ch);
    attr("compression", "compression", std::string(1, static_cast<char>(compression)));
    attr("dataWindow", "box2i", box(x1, y1));
    attr("displayWindow", "box2i", box(x1, y1));
    attr("lineOrder", "lineOrder", std::string(1, '\0'));
    s.push_back('\0');
    if (s.size() < total) s.resize(total, '\0');
    return s;
}

// The B44 bounds never refuse a real file: flat and noisy half images written
// by OpenEXR itself with B44 and B44A (the best case, 32 bytes in 3) load.
TEST(Exr, RealB44FilesStillLoad) {
    test::TempDir dir;
    for (const Imf::Compression c : {Imf::B44_COMPRESSION, Imf::B44A_COMPRESSION, Imf::PXR24_COMPRESSION,
                                     Imf::PIZ_COMPRESSION, Imf::DWAA_COMPRESSION, Imf::DWAB_COMPRESSION}) {
        for (const bool flat : {true, false}) {
            // Flat: the best case of every codec, large enough that a bound
            // too tight for it would show.
            const int w = flat ? 2048 : 256, h = flat ? 1024 : 128;
            std::vector<Imf::Rgba> px(static_cast<std::size_t>(w) * h);
            for (int i = 0; i < w * h; ++i) {
                const float v = flat ? 0.5f : static_cast<float>((i * 2654435761u) >> 24) / 255.0f;
                px[static_cast<std::size_t>(i)] = Imf::Rgba(v, v, v, 1.0f);
            }
            const auto file = dir / fmt::format("c{}_{}.exr", int(c), flat ? "flat" : "noise");
            {
                Imf::RgbaOutputFile out(file.c_str(), w, h, Imf::WRITE_RGBA, 1, Imath::V2f(0, 0), 1, Imf::INCREASING_Y,
                                        c);
                out.setFrameBuffer(px.data(), 1, static_cast<std::size_t>(w));
                out.writePixels(h);
            }
            std::printf("%s: %zu bytes for %d x %d RGBA halves\n", file.filename().c_str(),
                        static_cast<std::size_t>(std::filesystem::file_size(file)), w, h);
            const auto img = readExr(file);
            EXPECT_EQ(img.width(), w) << file;
            EXPECT_EQ(img.height(), h) << file;
        }
    }
}

}  // namespace

// A 240-byte EXR made OpenEXR allocate 2.6 GB before exr.cpp
// checked anything. The header is now read from the bytes first.
TEST(Exr, HostileHeaderIsRefusedBeforeOpenExrRuns) {
    test::TempDir dir;
    const std::string bytes = hostileExr(1 << 10, 1 << 30, 3, 240);
    ASSERT_EQ(bytes.size(), 240u);
    writeFileAtomic(dir / "hostile.exr", bytes);
    try {
        readExr(dir / "hostile.exr");
        FAIL() << "accepted a 2^30-line image from 240 bytes";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("hostile.exr"), std::string::npos) << e.what();
    }
    writeFileAtomic(dir / "inverted.exr", hostileExr(-5, 10, 0, 240));
    EXPECT_THROW(readExr(dir / "inverted.exr"), InputError);
    // Small window, enough offset table, but uncompressed samples missing.
    writeFileAtomic(dir / "short.exr", hostileExr(999, 3, 0, 240));
    EXPECT_THROW(readExr(dir / "short.exr"), InputError);
}

// Found by the fuzz campaign: two dataWindow attributes, 20000631x35 then
// 8x8. The pre-check read the second, OpenEXR allocated 3.8 GB for the first.
// A repeated attribute is refused.
TEST(Exr, RepeatedHeaderAttributeIsRefused) {
    const auto file = std::filesystem::path(MUCOSA_SOURCE_DIR) / "fuzz/corpus/exr/hostile_duplicate_datawindow.exr";
    ASSERT_TRUE(std::filesystem::exists(file));
    try {
        readExr(file);
        FAIL() << "accepted a header with two data windows";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("appears twice"), std::string::npos) << e.what();
    }
}

// Found by the campaign: 126 bytes declaring a 5832705x3 B44A image (70 MB
// of floats to allocate and decode); B44A codes 32 bytes in 3 at best.
TEST(Exr, B44HeaderWithoutTheDataIsRefused) {
    const auto file = std::filesystem::path(MUCOSA_SOURCE_DIR) / "fuzz/corpus/exr/hostile_b44a_no_data.exr";
    ASSERT_TRUE(std::filesystem::exists(file));
    try {
        readExr(file);
        FAIL() << "accepted a 5832705x3 B44A image from 12 bytes of data";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bytes present can hold at most"), std::string::npos) << e.what();
    }
}

// Found by CI's brief fuzzing: 231 bytes declaring a 421633x1793 DWAB image;
// OpenEXR allocated 431 MB for one chunk, the float image would have been
// 3 GB. PIZ and DWA now have a ratio bound too.
TEST(Exr, DwaHeaderWithoutTheDataIsRefused) {
    const auto file = std::filesystem::path(MUCOSA_SOURCE_DIR) / "fuzz/corpus/exr/hostile_dwab_no_data.exr";
    ASSERT_TRUE(std::filesystem::exists(file));
    try {
        readExr(file);
        FAIL() << "accepted a 421633x1793 DWAB image from 117 bytes of data";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bytes present can hold at most"), std::string::npos) << e.what();
    }
    for (std::uint8_t c : {std::uint8_t(4), std::uint8_t(8)}) {  // PIZ, DWAA: the same header
        test::TempDir dir;
        writeFileAtomic(dir / "h.exr", hostileExr(1 << 22, 31, c, 400));  // one chunk of 4194305 x 32
        try {
            readExr(dir / "h.exr");
            FAIL() << int(c);
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("bytes present can hold at most"), std::string::npos) << e.what();
        }
    }
}
