#pragma once
// The search both fits use (tune::fitToTarget, tune::fitLook): Hooke and
// Jeeves (1961), exploratory moves only, in parameters normalised to [0, 1].
// Each coordinate in turn tries +step and -step and keeps the better if it
// improves strictly; after a pass with no improvement the step halves, from
// 1/4 down to `tolerance`. Bounded by clamping to [0, 1]; deterministic
// (fixed order, strict improvement).
#include <algorithm>
#include <functional>
#include <vector>

namespace mucosa::tune::detail {

// `evaluate(u)` gives the objective at u (the caller caches and counts);
// `more()` says whether evaluations remain. `t` starts at the start point,
// whose objective is `best`; both end at the best point found.
inline void patternSearch(std::vector<double>& t, double& best,
                          const std::function<double(const std::vector<double>&)>& evaluate,
                          const std::function<bool()>& more, double tolerance) {
    double step = 0.25;
    while (step >= tolerance && more()) {
        bool improved = false;
        for (std::size_t i = 0; i < t.size() && more(); ++i) {
            std::vector<double> bestT = t;
            for (double sgn : {+1.0, -1.0}) {
                if (!more()) break;
                std::vector<double> u = t;
                u[i] = std::clamp(t[i] + sgn * step, 0.0, 1.0);
                if (u[i] == t[i]) continue;
                const double v = evaluate(u);
                if (v < best - 1e-12) {
                    best = v;
                    bestT = u;
                }
            }
            if (bestT != t) {
                t = bestT;
                improved = true;
            }
        }
        if (!improved) step *= 0.5;
    }
}

}  // namespace mucosa::tune::detail
