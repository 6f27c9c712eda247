#pragma once
// Video-to-CT registration: the pose of every bronchoscope frame on a mesh of
// the patient's airway (Deligianni, Chung, Yang: pq-space 2D/3D registration,
// MICCAI 2003; docs/theory.md "Registration").
//
// Video side: with the lamp at the optical centre, a Lambertian surface and
// local planarity, the log-intensity derivatives are linear in the surface
// gradient (p, q) and albedo and lamp power cancel (pqFromShading). Model side:
// the mesh rendered at a candidate pose, its normals lit by the same lamp and
// passed through the same estimator (pqFromModel), so that a lamp offset from
// the lens is modelled exactly. The pose maximises the confidence-weighted
// agreement of the two normal fields, tracked frame to frame, coarse to fine.
// The baseline: normalised cross-correlation of the frame with a Lambertian
// render at the candidate pose (intensity-based registration).
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/raster/raster.hpp>
#include <mucosa/shading/brdf.hpp>

namespace mucosa::registration {

enum class RegistrationMethod { PqSpace, Intensity };
const char* methodName(RegistrationMethod m) noexcept;

// A (p, q) field over a pinhole image: the surface z(X, Y) in camera space
// (OpenCV axes) has gradient (p, q), i.e. normal (p, q, -1) / sqrt(1 + p^2 + q^2)
// facing the camera. weight 0 = no estimate (masked).
// `normal`: the unit normal itself (camera axes, facing the camera), what the
// similarity compares. It is defined where (p, q) is not: a wall parallel to
// the optical axis (looking down a bronchus, most of it) has an infinite
// gradient, and one turned past it (at the view's edge) none; there p and q
// are held finite (c = 1 + a x + b y held at 0.01) and mean nothing.
struct PqField {
    int width = 0, height = 0;
    std::vector<float> p, q, weight;
    std::vector<std::array<float, 3>> normal;
    std::vector<std::uint8_t> usable;  // the pixels the local fits drew on
};

struct PqOptions {
    double smoothingPx = 2.0;    // Gaussian sigma of the log-intensity smoothing, working pixels
    double darkFraction = 0.04;  // below this fraction of the frame's 99th percentile: the dark lumen
    double saturation = 0.97;    // linear value at or above which a pixel is specular/clipped
    int borderPx = 2;            // image border (and field-of-view edge) masked, working pixels
    double minRayCosine = 0.1;   // the normal's cosine to the viewing ray below this: grazing, masked (video side)
    int albedoFilterPx = 0;      // opening + closing radius removing vessels and glints, both sides (0: off)
};

// Video side: `linear` is the frame's linear luminance (1 channel) resampled to
// an undistorted pinhole camera K; `valid` (optional, 1 = usable) marks the
// field of view and clipped pixels. Light at the optical centre.
PqField pqFromShading(const image::ImageF& linear, const frames::Intrinsics& K, const PqOptions& options,
                      const std::vector<std::uint8_t>* valid = nullptr);

// Model side at one pose: what the lamp (at `lightOffset`, camera space)
// shows of the surface the depth pass sees (interpolated mesh normals), as
// linear Lambertian irradiance n.l / d^2, rendered at `supersample` x the
// resolution and box-filtered like a camera's pixels.
struct ModelView {
    image::ImageF shading;           // 1 channel; 0 where nothing lit is seen
    image::ImageF depth;             // 1 channel, mean z of the sub-samples that hit (inf: none)
    std::vector<std::uint8_t> seen;  // 1: every sub-sample sees a lit surface
};
// `lamp`: the lamp's angular fall-off and disk (camera.json's light.spread,
// light.source_radius_mm), modelled so that the model's shading varies across
// the frame as the video's does.
// `brdf` (optional): shade with the patient's fitted rho(gamma) delta(z)
// instead (`mucosa fit`'s brdf.json), as the renderer's categories evaluate
// it: gamma = cos(V, N), z the distance to the viewpoint, the fall-off held
// at its ends beyond [zmin, zmax]; the lamp's offset and profile are then
// unused. A shading the lamp model does not describe (a measured fall-off
// that is not an inverse square) is then compared like with like.
// An albedo on the model (`texture`, optional): the patient's texture from
// `mucosa fit`, sampled through the mesh's UVs, multiplies the shading, so
// that the model shows the vessels and blotches the video does (features
// along a smooth airway that its shape alone does not have).
// Or an albedo per vertex of the mesh rendered (`perVertex`, when not empty:
// AlbedoMap's, learnt along the track; the atlas is then unused).
struct ModelTexture {
    image::ImageF luminance;  // 1 channel, linear; first row = v max (the atlas's convention)
    std::vector<float> perVertex;
    std::array<float, 2> uvMin{0, 0}, uvMax{1, 1};
    bool wrap = false;  // repeat (a tiling texture) instead of clamping at the rectangle's edge
    double at(double u, double v) const noexcept;  // bilinear
};
// The luminance (Rec. 709) of a linear RGB atlas spanning uvMin..uvMax, as
// `mucosa fit` writes it (texture.png with brdf.json's uv_min, uv_max).
ModelTexture modelTexture(const image::ImageF& linearRgb, std::array<float, 2> uvMin, std::array<float, 2> uvMax);
ModelView renderModel(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& cameraToWorld,
                      const frames::Vec3d& lightOffset, int threads = 1, int supersample = 2,
                      const frames::LampProfile& lamp = {}, const shading::BrdfParams* brdf = nullptr,
                      const ModelTexture* texture = nullptr);
// The same estimator on the model's shading: like is compared with like, so
// the estimator's own biases (curvature breaks local planarity; smoothing)
// and the lamp's offset from the lens are modelled exactly, not assumed away.
// On a plane with the lamp at the lens it returns the plane's gradient.
// `usable` (optional): the video field's usable pixels; the model's fits
// then draw on the same pixels as the video's (no lumen or glint the video
// could not use enters the model's estimate either).
PqField pqFromModel(const ModelView& view, const frames::Intrinsics& K, const PqOptions& options,
                    const std::vector<std::uint8_t>* usable = nullptr);

// Weighted mean cosine between the normals of two fields over pixels where
// `video` has weight; pixels the model does not see count as cosine 0.
double pqSimilarity(const PqField& video, const PqField& model);
// Normalised cross-correlation of two images over the pixels `valid` marks.
double normalisedCrossCorrelation(const image::ImageF& a, const image::ImageF& b,
                                  const std::vector<std::uint8_t>& valid);

// The first frame from a rough initial pose (placed by hand on the CT, or
// read off a navigation system): Levenberg-Marquardt from one start only
// captures a few millimetres and degrees. The search scores `candidates`
// poses around `initial` (it, and translations uniform in a ball of
// `radiusMm`, rotations of up to `degrees` about uniform axes; drawn from
// `seed`, so the same for every run) by the similarity at the coarsest
// working level, registers fully from the `refine` best and from `initial`,
// and keeps the best result (converged first, then the higher similarity).
struct InitialSearch {
    double radiusMm = 10.0, degrees = 20.0;
    int candidates = 240;
    int refine = 6;
    unsigned seed = 1;
    // Refined results scoring within `tie` of the best are taken as equally
    // good, and the one nearest the initial pose is kept: on the phantom, a
    // pose one tracheal ring (5 mm) along scored 0.006 above the truth's
    // 0.934, and the search kept it.
    double tie = 0.005;
};
// RegisterOptions::noLumenSearch's candidates for pq.
inline constexpr int kNoLumenSearchCandidates = 60;
// Its candidates for `options`' method (the default resolved).
struct RegisterOptions;
int noLumenSearchCandidates(const RegisterOptions& options) noexcept;

struct RegisterOptions {
    RegistrationMethod method = RegistrationMethod::PqSpace;
    // Working widths, coarse to fine (capped at the frame's width). The
    // smoothing is 2 working pixels, so the width sets its angular scale:
    // at 80 pixels across an 83-degree view, ~2 degrees (measured in
    // bench_register: 80 and 160 lost the track at 320 x 320, 40 and 80 held).
    std::vector<int> levels = {40, 80};
    int maxIterations = 12;       // Levenberg-Marquardt iterations per level
    double robustScale = 0.5;     // pq: Cauchy scale of |n_video - n_model|
    double albedoFilterPx = 0.0;  // pq: vessel/glint filter radius in the frame's pixels, scaled per level (0: off)
    int supersample = 2;          // model renders: sub-samples per pixel side
    double stepMm = 0.15, stepDeg = 0.3;  // finite-difference steps (at the finest level)
    double farMm = 120.0;                 // the depth pass sees this far
    // Below this (pq) a frame is flagged not converged. On the phantom's and
    // the CT airway's 300-frame sequences (2100 frames) the true poses scored
    // 0.960-0.995, and 0.93 flags the truth moved 5 mm sideways on all but
    // 79 frames of one smooth bronchus (docs/theory.md, "The thresholds on
    // the normals' scale"). A turn of 10 degrees can score as high as the
    // truth: FrameRegistration::poseSd, not the similarity, tells those.
    double minSimilarity = 0.93;
    double minCorrelation = 0.8;  // the same for the intensity method
    double saturation = 0.97;     // linear, specular/clipped
    frames::Vec3d lightOffset{0, 0, 0};
    frames::LampProfile lamp;  // the lamp's spread and disk (CameraModel::lamp)
    // The model's shading from a fitted brdf.json instead of the lamp
    // (`mucosa register --brdf`; see renderModel).
    std::optional<shading::BrdfParams> brdf;
    // The model's albedo (`mucosa register --fit DIR`; see ModelTexture).
    std::shared_ptr<const ModelTexture> texture;
    PqOptions pq;
    int threads = 0;
    // A prior on the frame's motion: the pose is drawn towards where it
    // started (the tracker's prediction) with a cost of `motionPrior` x (the
    // data cost of a mean squared residual of 1) x ((dt / priorMm)^2 +
    // (dw / priorDeg)^2), summed over the axes. Where the frame constrains the pose the data outweigh it; where it
    // does not (the roll looking down a round tube, the axial position in a
    // smooth one) the pose stays at the prediction instead of drifting to
    // whatever the noise favours. 0: off (the default: on 300-frame
    // sequences it helped on the phantom and hurt on the CT airway, see
    // docs/theory.md "A motion prior"; 0.0005 is the value measured best).
    double motionPrior = 0.0;
    // The same prior on the roll alone (the rotation about the optical axis,
    // sigma priorDeg), added to motionPrior's: the pose's least observable
    // axis looking down a round airway, held without holding back the
    // position or the viewing direction. 0: off (the default). In tracking
    // only (registerInitial refines its candidates without priors), with the
    // tracker's velocity as it is, 0.0005 helped category 4 seed 1
    // (p95 4.28 -> 3.60 degrees) and hurt lamp seed 1 (1.95 -> 4.30), so
    // it is not the default (docs/theory.md, "The track across a flagged
    // stretch"); 0.002 without the map held the CT airway's roll back.
    double rollPrior = 0.0;
    double priorMm = 1.0, priorDeg = 2.0;
    // recheck: when the coarse levels move the pose further than recheckMm /
    // recheckDeg from its start, the finest level is run from the start too
    // and the better result kept (registerFrame: a guard against a coarse
    // level's bias). registerInitial turns it on for the first frame; in
    // tracking it is off (on the lamp phantom it found a pose 6 mm / 22
    // degrees off that pq scored above the truth, and the track kept it).
    bool recheck = false;
    double recheckMm = 2.0, recheckDeg = 5.0;
    // With an albedo map (registerTracked's `map`): the motion prior, in
    // motionPrior's units, that holds the method's registration near the
    // pose the map gave (docs/theory.md, "An albedo learnt along the track").
    double albedoPrior = 0.002;
    // The three settings below decide which estimate a frame leaves and
    // which frames paint the albedo map. Together (the defaults) they
    // removed a 12 mm slide and its two losses on the
    // phantom's lamp sequence and left the other sequences within their
    // spread (docs/theory.md, "The map's pose as a check, and the
    // defaults").
    // With an albedo map: a frame the method does not converge on keeps the
    // map's step's pose (where that converged) as its estimate, still
    // flagged, instead of where the method's own iterations ended, and the
    // next frame starts from it.
    bool keepMapPose = true;
    // With an albedo map: a converged frame paints the map only when its
    // similarity is at least this (0: every converged frame paints), so
    // that frames converging just over pq's threshold (minSimilarity) do
    // not paint the map where they may be off: 0.95, under the lowest true
    // pose's 0.960 on the 300-frame sequences (0.80 over 0.78 before the
    // normals' scale). The same for the intensity method's NCC: on the
    // phantom its converged frames scored 0.97 or more.
    double minPaintSimilarity = 0.95;
    // With an albedo map: a frame the method converges on more than this many
    // millimetres or degrees from the map step's converged pose is flagged
    // (it paints nothing, and with keepMapPose takes the map's pose): the
    // shape and the wall's own albedo disagree, and one of them is wrong; on
    // the phantom it was the shape, 5 mm off at S 0.82. 0 turns a test off.
    double mapAgreementMm = 2.0, mapAgreementDegrees = 5.0;
    // With an albedo map: the map's step counts as converged only within this
    // many millimetres and degrees of where it started (the track's start).
    // The step has no prior, and further than a scope moves between frames
    // it has found another wall alike, not the frame's pose: on the CT
    // airway it converged 70 degrees off, and pq, started there, lost the
    // track. 0 turns a test off.
    double mapReachMm = 5.0, mapReachDegrees = 20.0;
    // A frame whose view at the estimate reaches no farther than this many
    // times its median depth (FrameRegistration::depthRange) is flagged,
    // FrameRegistration::noLumen: it faces the wall with no lumen in view,
    // where shape fixes the pose least (a wall seen face on barely changes
    // as the scope turns about its centre of curvature). On the CT airway
    // every frame more than 5 mm or 2 degrees off (59 of 300, all facing
    // the wall at the path's end, up to 71 degrees off at similarities
    // 0.88-0.98) was under 2.21, and all 1800 of the phantom's over 4.9
    // (docs/theory.md, "Frames with no lumen in view"). 0: off.
    double minDepthRange = 2.5;
    // registerTracked: a frame flagged for having no lumen in view is
    // searched for around the track's start, as a first frame is
    // (registerInitial: `candidates` draws within `radiusMm` and `degrees`
    // scored at the coarsest level, the best `refine` registered fully), and
    // the better-scoring of that and the tracked estimate kept, still
    // flagged (FrameRegistration::searched). Facing the wall the iterations
    // from the track stop in whatever valley they reach: on the CT airway
    // poses up to 46 degrees off that the truth outscored; searched, the
    // frames' worst was 14 degrees and the track was not lost
    // (docs/theory.md, "Searching a frame with no lumen in view").
    // `tie` is small: the truth outscored the tracked pose by 0.001-0.01.
    // Frames with the lumen in view are not searched. candidates 0: off;
    // -1 (the default): the method's, kNoLumenSearchCandidates for pq and
    // 0 for the intensity baseline, whose NCC on a wall outscores poses far
    // from the truth (searched, it lost the CT airway's track for good).
    InitialSearch noLumenSearch{3.0, 30.0, -1, 2, 1, 0.001};
};

struct FrameRegistration {
    frames::Mat4 cameraToWorld{};
    double similarity = 0;  // pq: weighted mean cosine; intensity: NCC
    int iterations = 0;     // summed over levels
    int evaluations = 0;    // renders
    bool converged = false;
    // The pose's standard deviation per axis, in the estimate's camera axes
    // (x right, y down, z forward): position in mm, then rotation about x,
    // y and z (the roll) in degrees. From the finest level's Gauss-Newton
    // normal equations at the last iteration, the residuals' variance and
    // the area over which they are correlated, measured from their
    // autocorrelation (docs/theory.md, "How well a frame fixes its pose"):
    // large on an axis the frame does not constrain (the roll down a round,
    // featureless tube), infinite on one no pixel responds to. NaN where no
    // iteration ran (an evaluation only).
    std::array<double, 6> poseSd{NAN, NAN, NAN, NAN, NAN, NAN};
    double renderSeconds = 0, similaritySeconds = 0, optimiserSeconds = 0;
    // registerTracked with an albedo map: whether the map's step converged
    // from any start, and its best such pose (a diagnostic, and the pose
    // RegisterOptions::keepMapPose keeps for a flagged frame).
    bool mapConverged = false;
    frames::Mat4 mapCameraToWorld{};
    // The method converged, but on a pose the map's step disagrees with
    // (RegisterOptions::mapAgreementMm): flagged for that.
    bool mapDisagreed = false;
    // Flagged, and the estimate is the map's step's converged pose
    // (RegisterOptions::keepMapPose), not where the method ended.
    bool mapPoseKept = false;
    // The ratio of the 99th percentile of the model's depth over the
    // frame's field of view, at the estimate, to its median (pixels beyond
    // the rendered neighbourhood count at RegisterOptions::farMm): 5-20
    // down a lumen, under 2.5 facing a wall. NaN if the model covers too
    // little of the view.
    double depthRange = NAN;
    // Flagged: the frame has no lumen in view (RegisterOptions::minDepthRange).
    bool noLumen = false;
    // The estimate is the search's around the track, run because the frame
    // had no lumen in view (RegisterOptions::noLumenSearch), which
    // outscored the tracked estimate; the track moves there (Tracker::update).
    bool searched = false;
};

// A frame prepared for registration: linear luminance at every level,
// resampled to an undistorted pinhole camera, with its validity mask.
struct VideoFrame {
    struct Level {
        frames::Intrinsics K;
        image::ImageF luminance;
        std::vector<std::uint8_t> valid;
        PqOptions pqOptions;  // the estimator's options at this level
        PqField pq;           // pq method only
    };
    std::vector<Level> levels;
};
// `linear`: the decoded frame (3 channels, linear), `saturated` as from
// loadFrameImage. Pixels outside the scope's field of view (black) are masked.
VideoFrame prepareFrame(const image::ImageF& linear, const image::Image8* saturated, const frames::Intrinsics& K,
                        const RegisterOptions& options);

// Registers one frame starting from `initial` (the previous frame's pose).
FrameRegistration registerFrame(const mesh::Mesh& mesh, const VideoFrame& frame, const frames::Mat4& initial,
                                const RegisterOptions& options);

// The triangles within `radiusMm` of a camera centre (the depth pass of a
// frame's neighbourhood; registration renders many poses near one point).
std::vector<std::uint32_t> trianglesNear(const mesh::Mesh& mesh, const frames::Vec3d& centre, double radiusMm);

// The next frame's starting pose under constant velocity: `last` moved by the
// motion from `before` to `last` (camera axes), scaled by `damping` (0: stay at
// `last`, 1: the full motion again).
frames::Mat4 predictPose(const frames::Mat4& before, const frames::Mat4& last, double damping = 0.5) noexcept;

// Frame-to-frame tracking: each frame starts from the last converged pose
// moved on by the last converged motion (constant velocity, times
// `prediction`; a velocity only between consecutive converged frames); a
// frame that does not converge leaves the track where it was and drops the
// velocity. The frame after a flagged one is registered from two starts
// (registerTracked): where the track was, and where the flagged frame
// ended, since a frame scoring just under the threshold at its true pose (a
// jerk of the scope, a glint) is usually right and the scope moves on
// meanwhile; or, where the flagged frame kept the albedo map's pose, from
// that pose alone (anchorOnMap).
class Tracker {
public:
    explicit Tracker(const frames::Mat4& initial, double prediction = 1.0) noexcept
        : last_(initial), before_(initial), prediction_(prediction) {}
    frames::Mat4 start() const noexcept { return haveBefore_ ? predictPose(before_, last_, prediction_) : last_; }
    // Every start for the next frame: start(), then the last flagged
    // frame's estimate if the frame before this one was flagged (and the
    // track did not move there).
    std::vector<frames::Mat4> starts() const {
        std::vector<frames::Mat4> s{start()};
        if (!fresh_ && flagged_ != last_) s.push_back(flagged_);
        return s;
    }
    // A flagged frame whose estimate is the albedo map's converged pose
    // (RegisterOptions::keepMapPose) moves the track there, without a
    // velocity: the next frame starts from it alone, not also from the last
    // converged pose, which a flagged stretch leaves many frames behind (on
    // the phantom the map's step, started 13 frames back, converged 11 mm
    // off and the track followed). false: the track stays at the last
    // converged pose and the map's pose is a second start.
    bool anchorOnMap = true;
    // The options for the next frame: the motion prior only around a fresh
    // prediction. After a flagged frame the start is where the track last
    // was, which the scope has left: a prior there would hold the pose back
    // (on the CT airway, where frames score low at their true pose, a prior
    // around every start froze the track: median 57 mm; without it, 0.93 mm).
    RegisterOptions options(RegisterOptions o) const noexcept {
        if (!fresh_) o.motionPrior = 0;
        return o;
    }
    // The velocity is taken only between two consecutive converged frames:
    // after a flagged stretch, the last converged pose lies many frames
    // back, and its motion to this frame applied again as one frame's would
    // throw the next start far ahead (on the phantom, 48 flagged frames then
    // a 5 mm jump the track kept for 28 frames).
    void update(const FrameRegistration& r) noexcept {
        const bool consecutive = fresh_;
        fresh_ = r.converged;
        if (!r.converged) {
            haveBefore_ = false;
            flagged_ = r.cameraToWorld;
            // A searched pose outscored the track's own, which lies behind the
            // scope as a flagged stretch goes on: the track moves there too.
            if ((anchorOnMap && r.mapPoseKept) || r.searched) {
                last_ = r.cameraToWorld;
                started_ = true;
            }
            return;
        }
        before_ = last_;
        haveBefore_ = started_ && consecutive;
        last_ = r.cameraToWorld;
        started_ = true;
    }

private:
    frames::Mat4 last_, before_, flagged_{};
    double prediction_;
    bool haveBefore_ = false, started_ = false, fresh_ = true;
};

// Whether a registered frame paints the albedo map: converged, and scoring
// at least RegisterOptions::minPaintSimilarity.
bool paintsAlbedoMap(const FrameRegistration& r, const RegisterOptions& o) noexcept;

// An albedo per vertex of the airway mesh, learnt from the frames as the
// track goes (photometric mapping, as direct visual SLAM keeps a map): the
// wall's vessels and blotches fix the axial position and roll that a smooth
// round tube's shape leaves free, and no texture from elsewhere is needed.
// Each frame added is divided by the model's shading at its registered pose
// (the untextured renderModel, per pixel of the finest level) and by its
// exposure (the median ratio to what the map already holds where it holds
// something; the first frame's median sets the scale), and the ratio is
// averaged into the triangle's three vertices, weighted by the barycentrics
// and by cos^2 / z^2 (a near, square view resolves the wall finest).
// Vertices never seen take the mean of the seen ones. See docs/theory.md,
// "An albedo learnt along the track".
class AlbedoMap {
public:
    explicit AlbedoMap(std::size_t vertices) : sum_(vertices, 0.0), weight_(vertices, 0.0) {}
    // Adds a frame registered at `cameraToWorld` (use converged frames only:
    // a frame added at a wrong pose paints the wall where it is not).
    // Returns the pixels used.
    std::size_t add(const mesh::Mesh& mesh, const VideoFrame& frame, const frames::Mat4& cameraToWorld,
                    const RegisterOptions& options);
    // The model texture for RegisterOptions::texture.
    std::shared_ptr<const ModelTexture> texture() const;
    double seenFraction() const noexcept;
    // A vertex's accumulated weight (0: never seen).
    double weight(std::size_t vertex) const noexcept { return weight_[vertex]; }
    std::size_t frames() const noexcept { return frames_; }

private:
    std::vector<double> sum_, weight_;
    std::size_t frames_ = 0;
};

// Registers the tracker's next frame from each of its starts, keeps the best
// (a converged result over a flagged one, then the higher similarity; timing,
// iterations and renders summed over the starts) and updates the tracker.
// With an albedo map that holds at least one frame, each start is first
// moved by registering the frame by intensity against the model carrying
// the map (the wall's own vessels and blotches: the motion the shape alone
// leaves free), then the method registers it from there, held near that
// pose by options.albedoPrior. A converged result is added to the map (the
// first frame's, from registerInitial, is the caller's to add).
FrameRegistration registerTracked(const mesh::Mesh& mesh, const VideoFrame& frame, Tracker& tracker,
                                  const RegisterOptions& options, AlbedoMap* map = nullptr);

FrameRegistration registerInitial(const mesh::Mesh& mesh, const VideoFrame& frame, const frames::Mat4& initial,
                                  const RegisterOptions& options, const InitialSearch& search = {});

// Pose error between two camera_to_world matrices: centre distance (mesh
// units) and rotation angle (degrees).
struct PoseError {
    double position = 0, degrees = 0;
};
PoseError poseError(const frames::Mat4& a, const frames::Mat4& b) noexcept;

// A pose moved by a translation (camera axes, mesh units) and a rotation
// vector (camera axes, radians): camera_to_world * [R(w) | t].
frames::Mat4 perturbPose(const frames::Mat4& cameraToWorld, const frames::Vec3d& translation,
                         const frames::Vec3d& rotation) noexcept;

}  // namespace mucosa::registration

namespace mucosa::registration {

// A run of `mucosa register` over a video, as written after every frame (a
// long run resumes where it stopped): the frames file `mucosa fit` reads, each
// frame with its registration (similarity, iterations, renders, converged).
struct RegisteredFrame {
    std::filesystem::path image;  // absolute or relative to the working folder
    FrameRegistration r;
};
struct RegistrationRun {
    frames::CameraModel camera;
    RegistrationMethod method = RegistrationMethod::PqSpace;
    std::string mesh;        // the mesh file, as given
    bool albedoMap = false;  // tracked with an albedo map (AlbedoMap)
    std::vector<RegisteredFrame> frames;
};
// Image paths are written relative to the output's folder. Atomic.
void writeRegistration(const std::filesystem::path& path, const RegistrationRun& run);
// Reads what writeRegistration wrote (for resuming); throws InputError if the
// file is not a registration.
RegistrationRun readRegistration(const std::filesystem::path& path);

// Refuses a starting view registration cannot work from (one InputError
// line): the mesh's normals facing out of the lumen, a pose outside the
// airway, looking out of an open end, or pressed against a wall.
void checkInitialView(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& pose,
                      const frames::Vec3d& lightOffset, const std::string& meshFile, const std::string& poseFile);

// `--report DIR`: index.html with the similarity trace (SVG) and, for up to
// `samples` frames spread over the run, the frame with the registered model's
// silhouette overlaid, next to the video's and the model's (p, q) fields
// (colour-coded normals). Images are written atomically into DIR.
void writeRegistrationReport(const std::filesystem::path& dir, const RegistrationRun& run, const mesh::Mesh& mesh,
                             const RegisterOptions& options, int samples = 6);

}  // namespace mucosa::registration
