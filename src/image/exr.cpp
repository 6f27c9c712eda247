#include <mucosa/image/exr.hpp>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>

#include <fmt/format.h>

namespace mucosa::image {

namespace {
std::vector<std::string> channelNames(int channels) {
    switch (channels) {
        case 1:
            return {"Y"};
        case 2:
            return {"Y", "A"};
        case 3:
            return {"R", "G", "B"};
        default:
            return {"R", "G", "B", "A"};
    }
}
std::uint32_t le32(const std::vector<std::byte>& b, std::size_t at) {
    return std::uint32_t(b[at]) | (std::uint32_t(b[at + 1]) << 8) | (std::uint32_t(b[at + 2]) << 16) |
           (std::uint32_t(b[at + 3]) << 24);
}

// Scanlines per chunk for each compression (OpenEXR file layout, "Compression").
int linesPerChunk(unsigned compression) {
    switch (compression) {
        case 0:  // NONE
        case 1:  // RLE
        case 2:  // ZIPS
            return 1;
        case 3:  // ZIP
        case 5:  // PXR24
            return 16;
        case 8:  // DWAA
            return 32;
        case 9:  // DWAB
            return 256;
        default:  // PIZ, B44, B44A
            return 32;
    }
}

// Reads the header from the bytes (OpenEXR file layout: magic, version, the
// attribute list up to its empty name) and refuses, before OpenEXR allocates
// anything, a file whose declared image the bytes present cannot describe.
void checkExrHeader(const std::vector<std::byte>& b, const std::string& name) {
    auto bad = [&](const std::string& why) { return InputError("EXR", name, why); };
    if (b.size() < 8 || le32(b, 0) != 20000630u) throw bad("not an OpenEXR file (bad magic number)");
    const std::uint32_t version = le32(b, 4);
    if ((version & 0xff) != 2) throw bad(fmt::format("unsupported version {}", version & 0xff));
    if (version & 0x1800u) throw bad("multi-part and deep files are not supported");
    const bool tiled = (version & 0x200u) != 0;
    const std::size_t maxName = (version & 0x400u) ? 255 : 31;
    std::size_t at = 8;
    auto readName = [&]() {
        std::string s;
        while (true) {
            if (at >= b.size()) throw bad("header is truncated");
            const char c = static_cast<char>(b[at++]);
            if (c == 0) return s;
            if (s.size() >= maxName) throw bad("attribute name is too long");
            s.push_back(c);
        }
    };
    bool haveWindow = false, haveCompression = false;
    std::int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    unsigned compression = 0;
    std::uint64_t channels = 0;
    std::vector<std::array<std::uint32_t, 2>> sampling;  // x, y sampling per channel
    std::set<std::string> seen;
    for (int count = 0;; ++count) {
        if (count > 10000) throw bad("header has too many attributes");
        const std::string attr = readName();
        if (attr.empty()) break;
        // One value per name: a second dataWindow (found by fuzz_exr) would let
        // this check read one window while OpenEXR allocates for the other.
        if (!seen.insert(attr).second) throw bad(fmt::format("attribute '{}' appears twice", attr));
        const std::string type = readName();
        if (at + 4 > b.size()) throw bad("header is truncated");
        const std::uint64_t size = le32(b, at);
        at += 4;
        if (size > b.size() - at) throw bad(fmt::format("attribute '{}' runs past the end of the file", attr));
        if ((attr == "dataWindow" && (type != "box2i" || size != 16)) ||
            (attr == "compression" && (type != "compression" || size != 1)) || (attr == "channels" && type != "chlist"))
            throw bad(fmt::format("attribute '{}' has type '{}' of {} bytes", attr, type.substr(0, 40), size));
        if (attr == "dataWindow") {
            x0 = static_cast<std::int32_t>(le32(b, at));
            y0 = static_cast<std::int32_t>(le32(b, at + 4));
            x1 = static_cast<std::int32_t>(le32(b, at + 8));
            y1 = static_cast<std::int32_t>(le32(b, at + 12));
            haveWindow = true;
        } else if (attr == "compression") {
            compression = unsigned(b[at]);
            haveCompression = true;
        } else if (attr == "channels") {
            // name\0 + 16 bytes per channel (pixel type, pLinear, 3 reserved,
            // x and y sampling), then a terminating \0. Subsampled channels
            // store fewer samples: count each at its own sampling.
            std::size_t p = at;
            const std::size_t end = at + size;
            while (p < end && b[p] != std::byte{0}) {
                while (p < end && b[p] != std::byte{0}) ++p;
                ++p;
                if (p + 16 <= end) {
                    const std::uint32_t xs = le32(b, p + 8), ys = le32(b, p + 12);
                    sampling.push_back({std::max<std::uint32_t>(xs, 1), std::max<std::uint32_t>(ys, 1)});
                }
                p += 16;
                ++channels;
            }
        }
        at += size;
    }
    if (!haveWindow || !haveCompression) throw bad("header lacks dataWindow or compression");
    if (x1 < x0 || y1 < y0) throw bad(fmt::format("data window ({},{})-({},{}) is inverted", x0, y0, x1, y1));
    const std::uint64_t w = std::uint64_t(x1 - x0) + 1, h = std::uint64_t(y1 - y0) + 1;
    if (w > (1u << 24) || h > (1u << 24)) throw bad(fmt::format("data window {}x{} is too large", w, h));
    const std::uint64_t fileLeft = b.size() - at;
    if (!tiled) {
        // The offset table holds one 8-byte offset per chunk and must be there.
        const std::uint64_t chunks = (h + linesPerChunk(compression) - 1) / linesPerChunk(compression);
        if (chunks * 8 > fileLeft)
            throw bad(fmt::format("{}x{} image needs an offset table of {} bytes but only {} bytes follow the header",
                                  w, h, chunks * 8, fileLeft));
    }
    // We read every channel as 32-bit float.
    const std::uint64_t pixelBytes =
        saturatingMul(saturatingMul(w, h), saturatingMul(std::max<std::uint64_t>(channels, 1), 4));
    // Half samples are 2 bytes; NONE stores them verbatim, RLE expands at most
    // 128 bytes per 2 coded, ZIP/ZIPS and PXR24 (a byte transform, then zlib)
    // at most deflate's 1032:1; B44 codes a 4x4 block of halves (32 bytes) in
    // 14 bytes, B44A a flat block in 3 (ratios under 3 and 11; other sample
    // types are stored raw). PIZ (a wavelet, then Huffman with run lengths)
    // and DWAA/DWAB (an 8x8 DCT, run lengths, then zlib) have no tight
    // bound; the DCT's 64:1 on a flat block times deflate's 1032:1 is
    // 66 048:1, so 2^17:1 is far above any real file and still refuses a
    // header whose bytes cannot hold its image (found by fuzz_exr: 231 bytes
    // declaring a 421633x1793 DWAB image, 431 MB that OpenEXR allocated for
    // one chunk before the 3 GB of floats were refused).
    std::uint64_t ratio = 0;
    if (compression == 0)
        ratio = 1;
    else if (compression == 1)
        ratio = 64;
    else if (compression == 2 || compression == 3 || compression == 5)
        ratio = 1032;
    else if (compression == 6)
        ratio = 3;
    else if (compression == 7)
        ratio = 11;
    else if (compression == 4 || compression == 8 || compression == 9)
        ratio = std::uint64_t(1) << 17;
    std::uint64_t rawMin = 0;
    for (const auto& [xs, ys] : sampling)
        rawMin += saturatingMul(saturatingMul((w + xs - 1) / xs, (h + ys - 1) / ys), 2);
    if (ratio != 0 && rawMin > saturatingMul(fileLeft + 1, ratio))
        throw bad(
            fmt::format("{}x{} image needs at least {} bytes of samples but the {} bytes present can hold at "
                        "most {}",
                        w, h, rawMin, fileLeft, saturatingMul(fileLeft + 1, ratio)));
    if (pixelBytes > availableMemoryBytes())
        throw ResourceError("EXR", name,
                            fmt::format("{}x{} image needs {}, more than available", w, h, formatBytes(pixelBytes)));
}

}  // namespace

const char* exrCompressionName(ExrCompression c) noexcept {
    switch (c) {
        case ExrCompression::None:
            return "none";
        case ExrCompression::Rle:
            return "rle";
        case ExrCompression::Zips:
            return "zips";
        case ExrCompression::Zip:
            return "zip";
        case ExrCompression::Piz:
            return "piz";
    }
    return "zip";
}

ExrCompression parseExrCompression(const std::string& name, const std::string& what, const std::string& where) {
    for (ExrCompression c :
         {ExrCompression::None, ExrCompression::Rle, ExrCompression::Zips, ExrCompression::Zip, ExrCompression::Piz})
        if (name == exrCompressionName(c)) return c;
    throw InputError(what, where, fmt::format("'{}' is not an EXR compression: none, rle, zips, zip or piz", name));
}

namespace {
std::atomic<bool> exrThreadsChosen{false};
}  // namespace

void setExrThreads(int threads) {
    if (threads < 0) throw InputError("EXR threads", "", "must be 0 or more");
    exrThreadsChosen = true;
    Imf::setGlobalThreadCount(threads);
}

void writeExr(const std::filesystem::path& path, const ImageF& img, ExrCompression compression) {
    if (img.empty()) throw InputError("image", path.string(), "is empty");
    // OpenEXR compresses a file's line blocks on its global thread pool, which
    // is empty unless the program sizes it: size it to the machine once,
    // unless the program already has (setExrThreads).
    static std::once_flag pool;
    std::call_once(pool, [] {
        if (!exrThreadsChosen.load())
            Imf::setGlobalThreadCount(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    });
    AtomicFile file(path);  // reserves the temporary name; OpenEXR writes it
    try {
        Imf::Header header(img.width(), img.height());
        switch (compression) {
            case ExrCompression::None:
                header.compression() = Imf::NO_COMPRESSION;
                break;
            case ExrCompression::Rle:
                header.compression() = Imf::RLE_COMPRESSION;
                break;
            case ExrCompression::Zips:
                header.compression() = Imf::ZIPS_COMPRESSION;
                break;
            case ExrCompression::Zip:
                header.compression() = Imf::ZIP_COMPRESSION;
                break;
            case ExrCompression::Piz:
                header.compression() = Imf::PIZ_COMPRESSION;
                break;
        }
        Imf::FrameBuffer fb;
        const auto names = channelNames(img.channels());
        const std::size_t xs = sizeof(float) * static_cast<std::size_t>(img.channels());
        for (int c = 0; c < img.channels(); ++c) {
            header.channels().insert(names[static_cast<std::size_t>(c)], Imf::Channel(Imf::FLOAT));
            fb.insert(names[static_cast<std::size_t>(c)],
                      Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(img.data()) + c), xs,
                                 xs * static_cast<std::size_t>(img.width())));
        }
        Imf::OutputFile out(file.temporaryPath().c_str(), header);
        out.setFrameBuffer(fb);
        out.writePixels(img.height());
    } catch (const std::exception& e) {
        throw IoError("EXR output", path.string(), e.what());
    }
    file.commit();
}

ImageF readExr(const std::filesystem::path& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError("input", path.string(), "no such file");
    checkExrHeader(readFile(path), path.string());
    try {
        Imf::InputFile in(path.c_str());
        const Imath::Box2i dw = in.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        std::vector<std::string> present;
        for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it)
            present.emplace_back(it.name());
        int channels = 1;
        std::vector<std::string> names;
        auto has = [&](const char* n) { return std::find(present.begin(), present.end(), n) != present.end(); };
        if (has("R") && has("G") && has("B")) {
            names = has("A") ? std::vector<std::string>{"R", "G", "B", "A"} : std::vector<std::string>{"R", "G", "B"};
        } else if (has("Y")) {
            names = {"Y"};
        } else if (!present.empty()) {
            names = {present.front()};
        } else {
            throw InputError("EXR", path.string(), "has no channels");
        }
        channels = static_cast<int>(names.size());
        ImageF img(w, h, channels);
        Imf::FrameBuffer fb;
        const std::size_t xs = sizeof(float) * static_cast<std::size_t>(channels);
        char* base = reinterpret_cast<char*>(img.data()) -
                     (static_cast<std::ptrdiff_t>(dw.min.x) + static_cast<std::ptrdiff_t>(dw.min.y) * w) *
                         static_cast<std::ptrdiff_t>(xs);
        for (int c = 0; c < channels; ++c)
            fb.insert(names[static_cast<std::size_t>(c)],
                      Imf::Slice(Imf::FLOAT, base + sizeof(float) * static_cast<std::size_t>(c), xs,
                                 xs * static_cast<std::size_t>(w)));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        return img;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError("EXR", path.string(), e.what());
    }
}

}  // namespace mucosa::image
