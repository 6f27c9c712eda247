#pragma once
// A machine observer: how well a classifier tells a user's real frames from
// rendered ones on the realism statistics (frame_stats.hpp) — the logistic
// observer of the realism tool (../shared/realism/observer.py), in C++:
//   - the 30 scored statistics of each frame, a NaN replaced by the
//     statistic's median over all frames (0 if none has it), plus one column
//     that is 1 where a frame had any NaN;
//   - L2-regularised logistic regression (C = 1, classes weighted to balance,
//     intercept not penalised, as scikit-learn's LogisticRegression) on
//     statistics standardised over the training frames;
//   - cross-validated: each real frame, and each of `groups` contiguous
//     groups of rendered frames (frames of one fly-through are alike), is
//     scored by a model that never saw it;
//   - AUC = P(score of a real frame > score of a rendered one), ties half:
//     0.5 = indistinguishable, 1 = told apart every time.
#include <vector>

#include <mucosa/tune/frame_stats.hpp>

namespace mucosa::tune {

// min_w,b 0.5 |w|^2 + C sum_i weight_i log(1 + exp(-y_i (w . x_i + b))),
// y_i in {-1, +1}; solved by Newton's method to a gradient of 1e-10.
struct LogisticModel {
    std::vector<double> w;
    double b = 0;
    double decision(const std::vector<double>& x) const;
};
LogisticModel fitLogistic(const std::vector<std::vector<double>>& x, const std::vector<int>& y,
                          const std::vector<double>& weight, double C = 1.0);

// P(pos > neg) + 0.5 P(pos == neg) over all pairs; NaN if either is empty.
double rocAuc(const std::vector<double>& pos, const std::vector<double>& neg);

struct ObserverResult {
    double auc = 0;
    std::vector<double> realScores, ourScores;  // held-out decision values
};
// groups <= 0: as many as there are real frames (observer.py's default),
// at most one per rendered frame. InputError when either set has fewer than
// 2 frames.
ObserverResult logisticObserver(const std::vector<FrameStats>& real, const std::vector<FrameStats>& ours,
                                int groups = 0);

}  // namespace mucosa::tune
