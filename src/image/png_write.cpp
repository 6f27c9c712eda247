// A PNG encoder built for large maps: the image is cut into pieces of whole
// rows (about 1 MiB each) that are generated, filtered (libpng's
// minimum-sum-of-absolute-differences heuristic) and deflated in parallel,
// pigz-style, so no whole filtered copy of the image is ever held: each piece
// ends with a sync flush (byte aligned, not final) so the pieces concatenate
// into one valid zlib stream (RFC 1950/1951) whose Adler-32 is combined from
// the pieces'. Noise-like pieces are Huffman-coded (deflate_huffman.cpp);
// others go through zlib primed with the previous 32 KiB as dictionary. The
// cut points and choices depend on the image only, so the bytes are the same
// for every thread count.
#include <mucosa/image/png.hpp>

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>

#include "core/simd.hpp"
#include "deflate_huffman.hpp"

namespace mucosa::image {

namespace {

constexpr std::size_t kPiece = std::size_t{1} << 20;
constexpr std::size_t kWindow = 32768;
constexpr std::size_t kIdatChunk = std::size_t{1} << 20;

void put32(std::vector<std::byte>& out, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::byte>((v >> s) & 0xFF));
}

void putChunk(std::vector<std::byte>& out, const char type[4], const std::byte* data, std::size_t n) {
    put32(out, static_cast<std::uint32_t>(n));
    const std::size_t typeAt = out.size();
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::byte>(type[i]));
    out.insert(out.end(), data, data + n);
    uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(out.data() + typeAt), static_cast<uInt>(4 + n));
    put32(out, static_cast<std::uint32_t>(crc));
}

// Branch-free Paeth predictor (PNG spec 9.4) so the filter loop vectorises.
inline int paeth(int a, int b, int c) {
    const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
    const int bc = pb <= pc ? b : c;
    return (pa <= pb && pa <= pc) ? a : bc;
}

inline int absResidual(int r) {
    return r < 128 ? r : 256 - r;
}

// Sum of |signed residual| of each filter type over one row (bytes >= bpp;
// the first bpp bytes are added by the caller). One pass, pure reductions.
MUCOSA_TARGET_CLONES void filterCosts(const std::uint8_t* __restrict cur, const std::uint8_t* __restrict prev,
                                      std::size_t n, std::size_t bpp, std::uint64_t cost[5]) {
    std::uint32_t c0 = 0, c1 = 0, c2 = 0, c3 = 0, c4 = 0;
    for (std::size_t i = bpp; i < n; ++i) {
        const int x = cur[i], a = cur[i - bpp], b = prev[i], c = prev[i - bpp];
        c0 += static_cast<std::uint32_t>(absResidual(x));
        c1 += static_cast<std::uint32_t>(absResidual((x - a) & 0xFF));
        c2 += static_cast<std::uint32_t>(absResidual((x - b) & 0xFF));
        c3 += static_cast<std::uint32_t>(absResidual((x - ((a + b) >> 1)) & 0xFF));
        c4 += static_cast<std::uint32_t>(absResidual((x - paeth(a, b, c)) & 0xFF));
    }
    cost[0] += c0;
    cost[1] += c1;
    cost[2] += c2;
    cost[3] += c3;
    cost[4] += c4;
}

MUCOSA_TARGET_CLONES void applyFilter(int type, const std::uint8_t* __restrict cur, const std::uint8_t* __restrict prev,
                                      std::size_t n, std::size_t bpp, std::uint8_t* __restrict out) {
    for (std::size_t i = 0; i < std::min(bpp, n); ++i) {
        const int x = cur[i], b = prev[i];
        const int pred = type == 2 || type == 4 ? b : (type == 3 ? (b >> 1) : 0);
        out[i] = static_cast<std::uint8_t>(x - pred);
    }
    switch (type) {
        case 0:
            std::memcpy(out + bpp, cur + bpp, n - bpp);
            break;
        case 1:
            for (std::size_t i = bpp; i < n; ++i) out[i] = static_cast<std::uint8_t>(cur[i] - cur[i - bpp]);
            break;
        case 2:
            for (std::size_t i = bpp; i < n; ++i) out[i] = static_cast<std::uint8_t>(cur[i] - prev[i]);
            break;
        case 3:
            for (std::size_t i = bpp; i < n; ++i)
                out[i] = static_cast<std::uint8_t>(cur[i] - ((cur[i - bpp] + prev[i]) >> 1));
            break;
        default:
            for (std::size_t i = bpp; i < n; ++i)
                out[i] = static_cast<std::uint8_t>(cur[i] - paeth(cur[i - bpp], prev[i], prev[i - bpp]));
            break;
    }
}

// Filters one row (PNG spec 9.2) into out[0] = type, out[1..] = bytes; picks
// the filter with the smallest sum of |signed residual| (libpng's heuristic).
void filterRow(const std::uint8_t* cur, const std::uint8_t* prev, std::size_t n, std::size_t bpp, std::uint8_t* out,
               std::vector<std::uint8_t>& zeros) {
    if (!prev) {
        zeros.assign(n, 0);
        prev = zeros.data();
    }
    bpp = std::min(bpp, n);
    std::uint64_t cost[5] = {};
    for (std::size_t i = 0; i < bpp; ++i) {
        const int x = cur[i], b = prev[i];
        cost[0] += static_cast<std::uint64_t>(absResidual(x));
        cost[1] += static_cast<std::uint64_t>(absResidual(x));
        cost[2] += static_cast<std::uint64_t>(absResidual((x - b) & 0xFF));
        cost[3] += static_cast<std::uint64_t>(absResidual((x - (b >> 1)) & 0xFF));
        cost[4] += static_cast<std::uint64_t>(absResidual((x - b) & 0xFF));
    }
    filterCosts(cur, prev, n, bpp, cost);
    int bestType = 0;
    for (int t = 1; t < 5; ++t)
        if (cost[t] < cost[bestType]) bestType = t;
    out[0] = static_cast<std::uint8_t>(bestType);
    applyFilter(bestType, cur, prev, n, bpp, out + 1);
}

struct Piece {
    std::vector<std::byte> deflated;
    uLong adler = 1;
    std::size_t length = 0;
};

// How a piece is deflated. Noise-like data (filtered normal maps) gains
// nothing from LZ77 matches: plain Huffman coding is both smaller and ~20x
// faster than zlib there. Filtered photographs and smooth gradients are
// mostly runs of small residuals: zlib's run-length strategy (matches at
// distance 1 only) finds what matters there at several times level 6's speed,
// often smaller (a 640x480 frame: 258 KiB in 4.8 ms against 295 KiB in 31 ms).
// Depth-like 16-bit data repeats at longer distances: full LZ77 at `level`.
enum class PieceCoding { Huffman, Rle, Lz77 };

// Probes a 64 KiB sample, four 16 KiB runs spread over the piece (its first
// rows alone can be all background): Huffman-only (estimated: the byte
// entropy, at least 1 bit a byte, a Huffman code's floor) unless zlib level 1
// or its run-length strategy beats it by 10 %; run-length where it comes
// within 5 % of level 1.
PieceCoding chooseCoding(const std::uint8_t* data, std::size_t n) {
    constexpr std::size_t kRuns = 4, kRun = 16384;
    if (n < 1024) return PieceCoding::Lz77;
    std::vector<std::uint8_t> sample;
    if (n <= kRuns * kRun) {
        sample.assign(data, data + n);
    } else {
        sample.reserve(kRuns * kRun);
        for (std::size_t r = 0; r < kRuns; ++r) {
            const std::uint8_t* at = data + r * ((n - kRun) / (kRuns - 1));
            sample.insert(sample.end(), at, at + kRun);
        }
    }
    const std::size_t m = sample.size();
    const double huffmanBytes = std::max(1.0, detail::byteEntropyBits(sample.data(), m)) * static_cast<double>(m) / 8.0;
    std::vector<Bytef> tmp(compressBound(static_cast<uLong>(m)) + 64);
    auto probe = [&](int strategy) {
        z_stream zs{};
        if (deflateInit2(&zs, 1, Z_DEFLATED, -15, 8, strategy) != Z_OK) return static_cast<double>(2 * m);
        zs.next_in = sample.data();
        zs.avail_in = static_cast<uInt>(m);
        zs.next_out = tmp.data();
        zs.avail_out = static_cast<uInt>(tmp.size());
        const int rc = deflate(&zs, Z_FINISH);
        const double bytes = rc == Z_STREAM_END ? static_cast<double>(zs.total_out) : static_cast<double>(2 * m);
        deflateEnd(&zs);
        return bytes;
    };
    const double lz = probe(Z_DEFAULT_STRATEGY), rle = probe(Z_RLE);
    if (std::min(lz, rle) > 0.9 * huffmanBytes) return PieceCoding::Huffman;
    return rle <= 1.05 * lz ? PieceCoding::Rle : PieceCoding::Lz77;
}

// A piece: whole rows [y0, y1), about kPiece filtered bytes. Filtering row y0
// needs row y0 - 1; a zlib piece also regenerates (and refilters) the rows
// behind it that hold the previous 32 KiB of filtered bytes, its dictionary.
struct PieceJob {
    std::size_t y0, y1;
};

void encodePiece(const PngRowSource& src, std::size_t rowBytes, std::size_t bpp, const PieceJob& job, bool last,
                 const PngWriteOptions& opt, Piece& out) {
    const std::size_t stride = rowBytes + 1;
    const std::size_t back = job.y0 == 0 ? 0 : std::min(job.y0, (kWindow + stride - 1) / stride);
    const std::size_t first = job.y0 - back;                  // first filtered row
    const std::size_t rawFirst = first == 0 ? 0 : first - 1;  // first generated row
    std::vector<std::uint8_t> raw((job.y1 - rawFirst) * rowBytes), filtered((job.y1 - first) * stride), zeros;
    const auto generate = [&](std::size_t a, std::size_t b) {
        for (std::size_t y = a; y < b; ++y) src.row(static_cast<int>(y), raw.data() + (y - rawFirst) * rowBytes);
    };
    const auto filter = [&](std::size_t a, std::size_t b) {
        for (std::size_t y = a; y < b; ++y) {
            const std::uint8_t* cur = raw.data() + (y - rawFirst) * rowBytes;
            filterRow(cur, y ? cur - rowBytes : nullptr, rowBytes, bpp, filtered.data() + (y - first) * stride, zeros);
        }
    };
    // The piece's own rows (and the row above them) decide its coding...
    generate(job.y0 == 0 ? 0 : job.y0 - 1, job.y1);
    filter(job.y0, job.y1);
    const std::uint8_t* data = filtered.data() + back * stride;
    const std::size_t n = (job.y1 - job.y0) * stride;
    const PieceCoding coding = opt.compression == PngCompression::Auto ? chooseCoding(data, n) : PieceCoding::Lz77;
    const bool huffmanOnly = coding == PieceCoding::Huffman;
    // ... and only zlib needs the rows behind them, for its dictionary.
    if (!huffmanOnly && back > 0) {
        generate(rawFirst, job.y0 - 1);
        filter(first, job.y0);
    }
    out.adler = adler32(1L, data, static_cast<uInt>(n));
    out.length = n;
    if (huffmanOnly) {
        std::vector<std::uint8_t> bytes;
        bytes.reserve(n + n / 8 + 1024);
        detail::deflateHuffmanOnly(data, n, last, bytes);
        out.deflated.resize(bytes.size());
        std::memcpy(out.deflated.data(), bytes.data(), bytes.size());
        return;
    }
    z_stream zs{};
    if (deflateInit2(&zs, opt.level, Z_DEFLATED, -15, 8, coding == PieceCoding::Rle ? Z_RLE : Z_DEFAULT_STRATEGY) !=
        Z_OK)
        throw InternalError("zlib deflateInit2 failed");
    if (back > 0) {
        const std::size_t dict = std::min(kWindow, back * stride);
        deflateSetDictionary(&zs, data - dict, static_cast<uInt>(dict));
    }
    out.deflated.resize(deflateBound(&zs, static_cast<uLong>(n)) + 16);
    zs.next_in = const_cast<Bytef*>(data);
    zs.avail_in = static_cast<uInt>(n);
    zs.next_out = reinterpret_cast<Bytef*>(out.deflated.data());
    zs.avail_out = static_cast<uInt>(out.deflated.size());
    const int rc = deflate(&zs, last ? Z_FINISH : Z_SYNC_FLUSH);
    if (rc != (last ? Z_STREAM_END : Z_OK) || zs.avail_in != 0) {
        deflateEnd(&zs);
        throw InternalError("zlib deflate did not complete a piece");
    }
    out.deflated.resize(out.deflated.size() - zs.avail_out);
    deflateEnd(&zs);
}

std::vector<std::byte> encodeRows(const PngRowSource& src, const PngWriteOptions& opt) {
    if (src.width < 1 || src.height < 1 || !src.row) throw InputError("image", "", "is empty");
    if (src.channels < 1 || src.channels > 4)
        throw InputError("image", "", fmt::format("has {} channels (PNG takes 1 to 4)", src.channels));
    if (src.bitDepth != 8 && src.bitDepth != 16)
        throw InputError("image", "", fmt::format("bit depth {} (8 or 16)", src.bitDepth));
    if (opt.level < 0 || opt.level > 9) throw InputError("PNG level", "", "must be 0..9");
    const int channels = src.channels;
    const int bitDepth = src.bitDepth;
    const std::size_t bpp = static_cast<std::size_t>(channels) * static_cast<std::size_t>(bitDepth / 8);
    const std::size_t rowBytes = static_cast<std::size_t>(src.width) * bpp;
    const std::size_t height = static_cast<std::size_t>(src.height);
    // Pieces of whole rows, about kPiece filtered bytes each; the cuts depend
    // on the image's shape only, so the bytes don't depend on the threads.
    const std::size_t rowsPerPiece = std::max<std::size_t>(1, kPiece / (rowBytes + 1));
    std::vector<PieceJob> jobs;
    for (std::size_t y = 0; y < height; y += rowsPerPiece) jobs.push_back({y, std::min(height, y + rowsPerPiece)});
    std::vector<Piece> pieces(jobs.size());
    tbb::task_arena arena(resolveThreads(opt.threads));
    arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, jobs.size(), [&](std::size_t i) {
            encodePiece(src, rowBytes, bpp, jobs[i], i + 1 == jobs.size(), opt, pieces[i]);
        });
    });
    std::vector<std::byte> zdata;
    std::size_t zsize = 2 + 4;
    for (const Piece& p : pieces) zsize += p.deflated.size();
    zdata.reserve(zsize);
    // RFC 1950 header: deflate, 32 KiB window, FLEVEL from the level, FCHECK.
    const int flevel = opt.compression == PngCompression::Auto ? 2
                       : opt.level <= 1                        ? 0
                                                               : (opt.level <= 5 ? 1 : (opt.level == 6 ? 2 : 3));
    const unsigned cmf = 0x78, flg0 = static_cast<unsigned>(flevel) << 6;
    const unsigned flg = flg0 + (31 - ((cmf * 256 + flg0) % 31)) % 31;
    zdata.push_back(static_cast<std::byte>(cmf));
    zdata.push_back(static_cast<std::byte>(flg));
    uLong adler = 1;
    for (const Piece& p : pieces) {
        zdata.insert(zdata.end(), p.deflated.begin(), p.deflated.end());
        adler = adler32_combine(adler, p.adler, static_cast<z_off_t>(p.length));
    }
    put32(zdata, static_cast<std::uint32_t>(adler));

    std::vector<std::byte> out;
    out.reserve(zdata.size() + zdata.size() / kIdatChunk * 12 + 128);
    const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    for (unsigned char c : sig) out.push_back(static_cast<std::byte>(c));
    std::array<std::byte, 13> ihdr{};
    auto be32 = [](std::byte* d, std::uint32_t v) {
        for (int i = 0; i < 4; ++i) d[i] = static_cast<std::byte>((v >> (24 - 8 * i)) & 0xFF);
    };
    be32(ihdr.data(), static_cast<std::uint32_t>(src.width));
    be32(ihdr.data() + 4, static_cast<std::uint32_t>(src.height));
    static constexpr std::uint8_t kColorType[5] = {0, 0, 4, 2, 6};
    ihdr[8] = static_cast<std::byte>(bitDepth);
    ihdr[9] = static_cast<std::byte>(kColorType[channels]);
    putChunk(out, "IHDR", ihdr.data(), ihdr.size());
    for (std::size_t at = 0; at < zdata.size(); at += kIdatChunk)
        putChunk(out, "IDAT", zdata.data() + at, std::min(kIdatChunk, zdata.size() - at));
    putChunk(out, "IEND", nullptr, 0);
    return out;
}

template <class T>
PngRowSource imageRows(const Image<T>& img) {
    if (img.empty()) throw InputError("image", "", "is empty");
    PngRowSource src{img.width(), img.height(), img.channels(), sizeof(T) == 1 ? 8 : 16, {}};
    src.row = [&img](int y, std::uint8_t* dst) {
        const T* row = img.row(y);
        if constexpr (sizeof(T) == 1) {
            std::memcpy(dst, row, img.rowStride());
        } else {
            for (std::size_t i = 0; i < img.rowStride(); ++i) {
                dst[2 * i] = static_cast<std::uint8_t>(row[i] >> 8);
                dst[2 * i + 1] = static_cast<std::uint8_t>(row[i] & 0xFF);
            }
        }
    };
    return src;
}

}  // namespace

std::vector<std::byte> encodePng(const PngRowSource& rows, const PngWriteOptions& opt) {
    return encodeRows(rows, opt);
}
std::vector<std::byte> encodePng(const Image8& img, const PngWriteOptions& opt) {
    return encodeRows(imageRows(img), opt);
}
std::vector<std::byte> encodePng(const Image16& img, const PngWriteOptions& opt) {
    return encodeRows(imageRows(img), opt);
}

void writePng(const std::filesystem::path& path, const Image8& img, const PngWriteOptions& opt) {
    writeFileAtomic(path, encodePng(img, opt));
}
void writePng(const std::filesystem::path& path, const Image16& img, const PngWriteOptions& opt) {
    writeFileAtomic(path, encodePng(img, opt));
}

}  // namespace mucosa::image
