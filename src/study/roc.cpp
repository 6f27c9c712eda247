#include <mucosa/study/stats.hpp>

#include <algorithm>

#include "ranks.hpp"

namespace mucosa::study {

RocResult roc(std::span<const int> positives, std::span<const int> negatives) {
    RocResult r;
    r.nPos = static_cast<int>(positives.size());
    r.nNeg = static_cast<int>(negatives.size());
    std::array<int, 7> pos{}, neg{};  // counts per score 0..6 (scores are 1..5)
    for (int s : positives) ++pos[static_cast<std::size_t>(std::clamp(s, 0, 6))];
    for (int s : negatives) ++neg[static_cast<std::size_t>(std::clamp(s, 0, 6))];
    int cp = 0, cn = 0;
    for (int t = 0; t <= 5; ++t) {
        cp += pos[static_cast<std::size_t>(t)];
        cn += neg[static_cast<std::size_t>(t)];
        r.points.push_back(
            {r.nNeg ? static_cast<double>(cn) / r.nNeg : 0.0, r.nPos ? static_cast<double>(cp) / r.nPos : 0.0});
    }
    for (std::size_t i = 1; i < r.points.size(); ++i)
        r.auc += (r.points[i][0] - r.points[i - 1][0]) * (r.points[i][1] + r.points[i - 1][1]) / 2;
    return r;
}

}  // namespace mucosa::study
