#pragma once
// A portable random stream for study plans: std::shuffle and the std::
// distributions differ between standard libraries, so a plan made on one
// machine would not be reproducible on another. SplitMix64 (Steele, Lea &
// Flood 2014) is small, fast and fully specified.
#include <cstdint>
#include <utility>
#include <vector>

namespace mucosa::study::detail {

class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    // Uniform in [0, n) without modulo bias (rejection of the short last range).
    std::size_t below(std::size_t n) {
        const std::uint64_t bound = static_cast<std::uint64_t>(n);
        const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % bound);
        std::uint64_t v;
        do {
            v = next();
        } while (v >= limit);
        return static_cast<std::size_t>(v % bound);
    }
    bool coin() { return (next() >> 63) != 0; }
    template <class T>
    void shuffle(std::vector<T>& v) {  // Fisher-Yates (Durstenfeld 1964)
        for (std::size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[below(i)]);
    }

private:
    std::uint64_t state_;
};

}  // namespace mucosa::study::detail
