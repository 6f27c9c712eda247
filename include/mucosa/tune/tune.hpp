#pragma once
// How the reflectance map's noise and the specular lobe shape the highlights,
// measured (the paper's future work: "the relationship between the noise
// functions used and the resultant tissue appearance"), and a preset fitted
// to target highlight statistics (highlight_stats.hpp):
//   - a probe renders a fixed set of views of a scene (poses along its camera
//     path) with some parameters changed and measures each view;
//   - sweep() varies one parameter at a time over its range, the others at
//     the scene's values;
//   - fitToTarget() searches the parameters (bounded pattern search with the
//     render in the loop) for the smallest sum over statistics of
//     |median - target median| / target IQR (the realism tool's distance).
// Takes a scene::Scene (mucosa::scene): callers link mucosa::tune, which
// brings mucosa::scene (or mucosa::mucosa).
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <mucosa/tune/highlight_stats.hpp>

namespace mucosa::scene {
struct Scene;
}

namespace mucosa::tune {

// A parameter the tuner varies: a reflectance map key or a scalar material
// parameter of the shading registry, with the range swept and searched (inside
// the registry's range, where the highlights change).
struct TuneParam {
    std::string_view key;  // "reflectance_map.frequency", "material.shininess", ...
    double min, max;
    bool logScale;           // spaced and searched in log(value)
    bool integer;            // rounded to a whole number (octaves; the frequency of a tileable map)
    std::string_view label;  // short, for plots
};
// Every tunable parameter; the first six are swept and fitted by default.
std::span<const TuneParam> tuneParams() noexcept;
std::vector<std::string> defaultTuneKeys();
// InputError(subject, "", "unknown parameter ... (did you mean ...; known: ...)").
const TuneParam& findTuneParam(std::string_view key, const std::string& subject = "--params");

// A parameter's normalised coordinate in [0, 1] over its range (in log for
// logScale) and back (rounded for integers); both clamp.
double toUnit(const TuneParam& p, double value);
double fromUnit(const TuneParam& p, double t);

double tuneValue(const scene::Scene& scene, const TuneParam& p);
// The values `params` take in `scene` when set from the normalised point
// `unit`: rounded where whole, a tileable map's frequency moved to one its
// lattice takes (the fits' cache key).
std::vector<double> appliedValues(const scene::Scene& scene, const std::vector<const TuneParam*>& params,
                                  const std::vector<double>& unit);
// Sets the value (rounded when p.integer); InputError when outside the registry's range.
void setTuneValue(scene::Scene& scene, const TuneParam& p, double value);

using TuneValues = std::vector<std::pair<const TuneParam*, double>>;

struct ProbeOptions {
    int views = 8;    // poses along the scene's camera path (each patient's)
    int size = 320;   // frames are size x size (measured at 320 x 320)
    int threads = 0;  // map generation
    // Besides the scene, patients 1..patients (scene::applyVariation, each
    // on its own survey: camera.path.seed = the patient), `views` each.
    int patients = 0;
    // The values are a look (scene::applyLook): the centre the patients vary
    // about. Otherwise they are set as they are (setTuneValue).
    bool asLook = false;
};

// Renders `views` poses of a scene offscreen (EGL) and measures them. The
// map is regenerated only when a map parameter changes.
class HighlightProbe {
public:
    HighlightProbe(const scene::Scene& base, const ProbeOptions& options);
    ~HighlightProbe();
    HighlightProbe(const HighlightProbe&) = delete;
    HighlightProbe& operator=(const HighlightProbe&) = delete;

    // The base scene with `values` applied, every view measured.
    std::vector<FrameHighlights> measure(const TuneValues& values);
    // The base scene with `values` applied, every view rendered (kept until
    // the next call). The generated texture is made again when a tissue
    // parameter changes.
    const std::vector<image::Image8>& renderViews(const TuneValues& values);
    // The frames of the last measure(), in view order.
    const std::vector<image::Image8>& lastFrames() const noexcept;
    const scene::Scene& base() const noexcept;
    std::string glRenderer() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// ------------------------------------------------------------------ sweep
struct SweepOptions {
    std::vector<std::string> params;  // keys; empty = defaultTuneKeys()
    int steps = 7;                    // values per parameter (plus the scene's own value)
    ProbeOptions probe;
    // After each evaluated value: (done, total).
    std::function<void(int done, int total)> progress;
};
struct SweepPoint {
    const TuneParam* param = nullptr;
    double value = 0;
    bool isBase = false;  // the scene's own value
    std::vector<FrameHighlights> views;
    HighlightSummary summary;  // median and IQR over the views
};
struct SweepResult {
    std::vector<const TuneParam*> params;
    std::vector<double> baseValues;  // per param
    std::vector<SweepPoint> points;  // grouped by param, values ascending
    int views = 0, size = 0;
};
// The values swept for `p`: `steps` evenly spaced (in log for logScale)
// from min to max, plus `base`, rounded for integers, ascending, distinct.
std::vector<double> sweepValues(const TuneParam& p, int steps, double base);
SweepResult sweep(const scene::Scene& scene, const SweepOptions& options);

// Table: param, value, base, then per statistic median, q1, q3.
std::string sweepTsv(const SweepResult& r);
// The same with every view's values, as JSON (null = no value).
std::string sweepJson(const SweepResult& r, const HighlightSummary* target = nullptr);
// One statistic against every swept parameter, small multiples (one panel per
// parameter; median over the views with the IQR shaded; the scene's value
// dashed; the target's median and IQR as a green band when given).
std::string sweepSvg(const SweepResult& r, HighlightStat stat, const HighlightSummary* target = nullptr);

// ------------------------------------------------------------------ fit
struct TuneFitOptions {
    std::vector<std::string> params;   // keys; empty = defaultTuneKeys()
    std::vector<HighlightStat> stats;  // summed; empty = all eight
    ProbeOptions probe;
    int maxEvaluations = 80;  // renders of the view set
    // Search ends when the step (in the normalised [0, 1] range of each
    // parameter) falls below this.
    double tolerance = 1.0 / 64;
    // After each evaluation: (evaluations, maxEvaluations, best distance so far).
    std::function<void(int done, int total, double best)> progress;
};
struct TuneFitResult {
    TuneValues start, best;
    Distance before, after;
    HighlightSummary beforeSummary, afterSummary;
    int evaluations = 0;
};
// Coordinate pattern search (Hooke and Jeeves 1961) in the normalised range,
// from the scene's values; deterministic.
TuneFitResult fitToTarget(const scene::Scene& scene, const HighlightSummary& target, const TuneFitOptions& options);

// The fitted look as a scene file fragment: {"reflectance_map": {every map
// key, or with everyMapKey false only those in `values`}, "material",
// "camera", "light": {the registry values in `values`}, "tissue": {the
// texture's}}: the keys of a scene's objects (docs/scene-format.md); with a
// "mesh" added it is a scene file of its own, and `--look` reads it as it is.
std::string presetJson(const scene::Scene& scene, const TuneValues& values, bool everyMapKey = true);

}  // namespace mucosa::tune
