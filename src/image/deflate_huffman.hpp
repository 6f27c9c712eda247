#pragma once
// A Huffman-only DEFLATE encoder (RFC 1951, dynamic blocks of literals only).
// For PNG-filtered noise maps the residuals are close to white noise: LZ77
// finds almost nothing, and zlib level 6 spends ~7 s on a 4096^2 map to end up
// *larger* than plain Huffman coding (measured: 0.90 x the size, 20 x faster).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mucosa::image::detail {

// Appends raw DEFLATE blocks coding `data` to `out`; blocks cover at most
// `blockSize` bytes each, each with its own code. When `final` is false the
// output ends with an empty stored block (a sync flush) so that it is byte
// aligned and another piece can follow; when true the last block is final.
void deflateHuffmanOnly(const std::uint8_t* data, std::size_t size, bool final, std::vector<std::uint8_t>& out,
                        std::size_t blockSize = std::size_t{1} << 17);

// Estimated Huffman-only cost of `data` in bits per byte (Shannon entropy of
// the byte histogram), used to pick between this encoder and zlib.
double byteEntropyBits(const std::uint8_t* data, std::size_t size);

// Huffman code lengths for `freq` (n symbols), limited to `maxBits`; symbols
// with zero frequency get length 0. Exposed for tests.
std::vector<std::uint8_t> huffmanLengths(const std::vector<std::uint32_t>& freq, int maxBits);

}  // namespace mucosa::image::detail
