#pragma once
// A look fitted to a user's own real frames (`mucosa look fit`, docs/look.md):
// the tissue's colour and texture, the vessels, the mucus, the highlights,
// the exposure and light profile and the camera's softness and noise are
// searched, with the renderer in the loop, for the frames a machine can least
// tell from the real ones:
//   objective = the realism score (the mean over the 30 statistics of
//               |median - real median| / real IQR, frame_stats.hpp)
//             + observerWeight x (AUC - 0.5) of the logistic observer
//               (observer.hpp) trained on the same statistics.
// The score pulls every statistic's median to the real one; the observer
// adds what medians miss (spreads, joint differences).
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <mucosa/tune/frame_stats.hpp>
#include <mucosa/tune/observer.hpp>
#include <mucosa/tune/tune.hpp>

namespace mucosa::tune {

enum class LookGroup { Colour, Texture, Mucus, Highlights, Exposure, Camera };
std::string_view lookGroupName(LookGroup g) noexcept;

struct LookParam {
    std::string_view key;  // a tuneParams() key
    LookGroup group;
};
// The parameters `fitLook` searches by default, in search order.
std::span<const LookParam> lookParams() noexcept;
LookGroup lookGroup(const TuneParam& p) noexcept;  // Highlights for the map's and lobe's parameters

struct LookEvaluation {
    double objective = 0;
    RealismScore realism;
    double auc = 0;  // the logistic observer's, cross-validated
    FrameStatsSummary summary;
};
// The objective of a set of rendered frames' statistics against the target's.
LookEvaluation evaluateLook(const std::vector<FrameStats>& target, const FrameStatsSummary& targetSummary,
                            const std::vector<FrameStats>& ours, double observerWeight, int observerGroups = 0);

struct LookFitOptions {
    std::vector<std::string> params;  // tuneParams() keys; empty = lookParams()
    // Views along the scene's camera path, their size, and patients drawn
    // about the look (each with views of its own); the values are applied as
    // a look (ProbeOptions::asLook) whatever the probe says.
    ProbeOptions probe{16, 480, 0, 0, true};
    int maxEvaluations = 300;     // renders of the view set
    double tolerance = 1.0 / 32;  // smallest step, in each parameter's normalised range
    double observerWeight = 1.0;
    int observerGroups = 0;  // rendered frames held out together; 0: as many as the real frames
    // After each new evaluation: (evaluations, maxEvaluations, best objective so far).
    std::function<void(int done, int total, double best)> progress;
};
struct LookFitResult {
    TuneValues start, best;
    LookEvaluation before, after;
    int evaluations = 0;
    std::vector<image::Image8> frames;  // the views at the fitted look
};
// Coordinate pattern search (detail::patternSearch) from the scene's values;
// deterministic. InputError for fewer than 2 target frames, an unknown or
// repeated parameter, a scene mode that reads no map.
LookFitResult fitLook(const scene::Scene& scene, const std::vector<FrameStats>& target, const LookFitOptions& options);

}  // namespace mucosa::tune
