#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <numeric>

#include "ranks.hpp"

namespace mucosa::study {

std::vector<double> averageRanks(std::span<const double> values) {
    const std::size_t n = values.size();
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
    std::vector<double> ranks(n);
    std::size_t i = 0;
    while (i < n) {
        std::size_t j = i + 1;
        while (j < n && values[order[j]] == values[order[i]]) ++j;
        // Ranks i+1..j share their mean (i + 1 + j) / 2.
        const double r = 0.5 * static_cast<double>(i + 1 + j);
        for (std::size_t m = i; m < j; ++m) ranks[order[m]] = r;
        i = j;
    }
    return ranks;
}

}  // namespace mucosa::study
