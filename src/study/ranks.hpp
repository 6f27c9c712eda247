#pragma once
// Helpers shared by the rank tests (Friedman, Wilcoxon, Mann-Whitney).
#include <cmath>
#include <string>
#include <vector>

namespace mucosa::study::detail {

inline void setWhy(std::string* why, const std::string& text) {
    if (why) *why = text;
}

// Sizes of groups of equal values among sorted values (only groups > 1 matter).
template <class F>
void forEachTieGroup(const std::vector<double>& sorted, F&& f) {
    std::size_t i = 0;
    while (i < sorted.size()) {
        std::size_t j = i + 1;
        while (j < sorted.size() && sorted[j] == sorted[i]) ++j;
        if (j - i > 1) f(static_cast<double>(j - i));
        i = j;
    }
}

}  // namespace mucosa::study::detail
