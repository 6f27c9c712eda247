#include "deflate_huffman.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <queue>

#include <mucosa/core/error.hpp>

namespace mucosa::image::detail {

namespace {

inline std::uint64_t toLittleEndian(std::uint64_t v) noexcept {
    if constexpr (std::endian::native == std::endian::little)
        return v;
    else
        return __builtin_bswap64(v);
}

// LSB-first bit writer (RFC 1951 3.1.1) into a buffer sized up front; flushes
// whole 32-bit words.
class BitWriter {
public:
    explicit BitWriter(std::vector<std::uint8_t>& out) : out_(out) {}
    void put(std::uint32_t bits, int n) {
        acc_ |= static_cast<std::uint64_t>(bits) << count_;
        count_ += n;
        if (count_ >= 32) {
            const std::size_t at = out_.size();
            if (out_.capacity() < at + 4) out_.reserve(2 * at + 64);
            out_.resize(at + 4);
            const auto word = static_cast<std::uint32_t>(acc_);
            std::uint8_t* d = out_.data() + at;
            d[0] = static_cast<std::uint8_t>(word);
            d[1] = static_cast<std::uint8_t>(word >> 8);
            d[2] = static_cast<std::uint8_t>(word >> 16);
            d[3] = static_cast<std::uint8_t>(word >> 24);
            acc_ >>= 32;
            count_ -= 32;
        }
    }
    // Hot loop: codes of at most 15 bits, written through a raw pointer into
    // space reserved by the caller (n * 2 bytes is always enough). Branch-free:
    // three codes (<= 45 bits) join the < 8 pending bits, then all whole bytes
    // go out in one unaligned 64-bit little-endian store.
    void putSymbols(const std::uint8_t* data, std::size_t n, const std::uint32_t* code, const std::uint8_t* len) {
        // Drain the pending bits to fewer than 8 first.
        while (count_ >= 8) {
            out_.push_back(static_cast<std::uint8_t>(acc_));
            acc_ >>= 8;
            count_ -= 8;
        }
        std::size_t at = out_.size();
        out_.resize(at + 2 * n + 16);
        std::uint8_t* d = out_.data();
        std::uint64_t acc = acc_;
        unsigned count = static_cast<unsigned>(count_);
        const auto flush = [&] {
            const std::uint64_t le = toLittleEndian(acc);
            std::memcpy(d + at, &le, sizeof le);
            at += count >> 3;
            acc >>= (count & ~7u);
            count &= 7u;
        };
        std::size_t i = 0;
        for (; i + 3 <= n; i += 3) {
            const std::uint8_t s0 = data[i], s1 = data[i + 1], s2 = data[i + 2];
            acc |= static_cast<std::uint64_t>(code[s0]) << count;
            count += len[s0];
            acc |= static_cast<std::uint64_t>(code[s1]) << count;
            count += len[s1];
            acc |= static_cast<std::uint64_t>(code[s2]) << count;
            count += len[s2];
            flush();
        }
        for (; i < n; ++i) {
            acc |= static_cast<std::uint64_t>(code[data[i]]) << count;
            count += len[data[i]];
            flush();
        }
        out_.resize(at);
        acc_ = acc;
        count_ = static_cast<int>(count);
    }
    void alignToByte() {
        while (count_ > 0) {
            out_.push_back(static_cast<std::uint8_t>(acc_));
            acc_ >>= 8;
            count_ = std::max(0, count_ - 8);
        }
        acc_ = 0;
        count_ = 0;
    }

private:
    std::vector<std::uint8_t>& out_;
    std::uint64_t acc_ = 0;
    int count_ = 0;
};

std::uint32_t reverseBits(std::uint32_t code, int len) {
    std::uint32_t r = 0;
    for (int i = 0; i < len; ++i) r |= ((code >> i) & 1u) << (len - 1 - i);
    return r;
}

// Canonical codes (RFC 1951 3.2.2), bit-reversed for LSB-first output.
std::vector<std::uint32_t> canonicalCodes(const std::vector<std::uint8_t>& lengths) {
    int blCount[16] = {};
    for (std::uint8_t l : lengths) blCount[l]++;
    blCount[0] = 0;
    std::uint32_t next[16] = {};
    std::uint32_t code = 0;
    for (int bits = 1; bits < 16; ++bits) {
        code = (code + static_cast<std::uint32_t>(blCount[bits - 1])) << 1;
        next[bits] = code;
    }
    std::vector<std::uint32_t> codes(lengths.size(), 0);
    for (std::size_t s = 0; s < lengths.size(); ++s)
        if (lengths[s]) codes[s] = reverseBits(next[lengths[s]]++, lengths[s]);
    return codes;
}

constexpr int kCodeLengthOrder[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};

void writeBlock(BitWriter& bw, const std::uint8_t* data, std::size_t n, bool last) {
    // Literal/length alphabet: 0..255 literals, 256 end of block.
    std::vector<std::uint32_t> freq(257, 0);
    for (std::size_t i = 0; i < n; ++i) freq[data[i]]++;
    freq[256] = 1;
    std::vector<std::uint8_t> litLen = huffmanLengths(freq, 15);
    const std::vector<std::uint32_t> litCode = canonicalCodes(litLen);
    // Two distance codes of length 1: a complete (if unused) code, which every
    // inflater accepts.
    const std::uint8_t distLen[2] = {1, 1};

    // Code lengths sent as plain code-length symbols 0..15 (no run-length).
    std::vector<std::uint32_t> clFreq(19, 0);
    for (std::uint8_t l : litLen) clFreq[l]++;
    clFreq[1] += 2;
    std::vector<std::uint8_t> clLen = huffmanLengths(clFreq, 7);
    const std::vector<std::uint32_t> clCode = canonicalCodes(clLen);
    int hclen = 19;
    while (hclen > 4 && clLen[static_cast<std::size_t>(kCodeLengthOrder[hclen - 1])] == 0) --hclen;

    bw.put(last ? 1u : 0u, 1);
    bw.put(2u, 2);  // dynamic Huffman
    bw.put(0u, 5);  // HLIT = 257 - 257
    bw.put(1u, 5);  // HDIST = 2 - 1
    bw.put(static_cast<std::uint32_t>(hclen - 4), 4);
    for (int i = 0; i < hclen; ++i) bw.put(clLen[static_cast<std::size_t>(kCodeLengthOrder[i])], 3);
    for (std::uint8_t l : litLen) bw.put(clCode[l], clLen[l]);
    for (std::uint8_t l : distLen) bw.put(clCode[l], clLen[l]);

    bw.putSymbols(data, n, litCode.data(), litLen.data());
    bw.put(litCode[256], litLen[256]);
}

}  // namespace

std::vector<std::uint8_t> huffmanLengths(const std::vector<std::uint32_t>& freqIn, int maxBits) {
    const std::size_t n = freqIn.size();
    std::vector<std::uint8_t> lengths(n, 0);
    std::vector<std::uint64_t> freq(freqIn.begin(), freqIn.end());
    std::size_t used = 0, lastUsed = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (freq[i]) {
            ++used;
            lastUsed = i;
        }
    if (used == 0) return lengths;
    if (used == 1) {  // a code needs two symbols to be complete
        lengths[lastUsed] = 1;
        lengths[lastUsed == 0 ? 1 : 0] = 1;
        return lengths;
    }
    for (;;) {
        // Standard Huffman construction over a min-heap of (weight, node).
        struct Node {
            std::uint64_t w;
            int left, right;
        };
        std::vector<Node> nodes;
        nodes.reserve(2 * used);
        using Item = std::pair<std::uint64_t, int>;
        std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
        std::vector<int> leafOf;
        for (std::size_t i = 0; i < n; ++i)
            if (freq[i]) {
                nodes.push_back({freq[i], -1, static_cast<int>(i)});
                heap.push({freq[i], static_cast<int>(nodes.size() - 1)});
            }
        while (heap.size() > 1) {
            const auto [wa, a] = heap.top();
            heap.pop();
            const auto [wb, b] = heap.top();
            heap.pop();
            nodes.push_back({wa + wb, a, b});
            heap.push({wa + wb, static_cast<int>(nodes.size() - 1)});
        }
        // Depths by an explicit stack walk.
        int maxDepth = 0;
        std::vector<std::pair<int, int>> stack{{heap.top().second, 0}};
        std::fill(lengths.begin(), lengths.end(), 0);
        while (!stack.empty()) {
            const auto [node, depth] = stack.back();
            stack.pop_back();
            const Node& nd = nodes[static_cast<std::size_t>(node)];
            if (nd.left < 0) {
                lengths[static_cast<std::size_t>(nd.right)] = static_cast<std::uint8_t>(depth);
                maxDepth = std::max(maxDepth, depth);
            } else {
                stack.push_back({nd.left, depth + 1});
                stack.push_back({nd.right, depth + 1});
            }
        }
        if (maxDepth <= maxBits) return lengths;
        // Too deep: flatten the distribution and rebuild (zlib's approach is
        // exact; this converges in a couple of rounds and costs < 0.1 %).
        for (std::uint64_t& f : freq)
            if (f) f = (f >> 1) | 1;
    }
}

double byteEntropyBits(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0.0;
    std::uint64_t h[256] = {};
    for (std::size_t i = 0; i < size; ++i) h[data[i]]++;
    double bits = 0;
    for (std::uint64_t c : h)
        if (c) {
            const double p = static_cast<double>(c) / static_cast<double>(size);
            bits -= p * std::log2(p);
        }
    return bits;
}

void deflateHuffmanOnly(const std::uint8_t* data, std::size_t size, bool final, std::vector<std::uint8_t>& out,
                        std::size_t blockSize) {
    MUCOSA_CHECK(blockSize > 0, "block size");
    BitWriter bw(out);
    std::size_t at = 0;
    do {
        const std::size_t n = std::min(blockSize, size - at);
        const bool last = final && at + n == size;
        writeBlock(bw, data + at, n, last);
        at += n;
    } while (at < size);
    if (!final) {
        // Sync flush: an empty stored block byte-aligns the stream.
        bw.put(0u, 3);
        bw.alignToByte();
        out.push_back(0x00);
        out.push_back(0x00);
        out.push_back(0xFF);
        out.push_back(0xFF);
    } else {
        bw.alignToByte();
    }
}

}  // namespace mucosa::image::detail
