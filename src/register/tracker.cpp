// The tracker: each frame registered from the track's starts (with the
// albedo map's step first when there is a map), the best kept, and a frame
// with no lumen in view searched for around the track (registerTracked); the
// constant-velocity prediction of the next start.
#include <mucosa/register/register.hpp>

#include <optional>

#include <Eigen/Dense>

#include "phases.hpp"

namespace mucosa::registration {

using detail::Mat3;
using detail::outranks;
using detail::rotationOf;

namespace detail {

bool outranks(const FrameRegistration& a, const FrameRegistration& b) noexcept {
    return (a.converged && !b.converged) || (a.converged == b.converged && a.similarity > b.similarity);
}

}  // namespace detail

FrameRegistration registerTracked(const mesh::Mesh& mesh, const VideoFrame& frame, Tracker& tracker,
                                  const RegisterOptions& o, AlbedoMap* map) {
    const RegisterOptions options = tracker.options(o);
    const bool mapped = map && map->frames() > 0;
    // The map's step: intensity against the model carrying the albedo, free.
    RegisterOptions byMap = o;
    if (mapped) {
        byMap.method = RegistrationMethod::Intensity;
        byMap.texture = map->texture();
        byMap.motionPrior = byMap.rollPrior = 0;
        // The wall's albedo is the evidence a frame with no lumen in view
        // has left: the map's step is not flagged for it.
        byMap.minDepthRange = 0;
    }
    FrameRegistration best;
    bool have = false;
    // The map's step where it converged: the estimate kept for a frame the
    // method itself does not converge on.
    std::optional<FrameRegistration> byMapBest;
    double render = 0, similarity = 0, optimiser = 0;
    int iterations = 0, evaluations = 0;
    for (const frames::Mat4& trackStart : tracker.starts()) {
        frames::Mat4 start = trackStart;
        RegisterOptions method = options;
        if (mapped) {
            const FrameRegistration m = registerFrame(mesh, frame, trackStart, byMap);
            render += m.renderSeconds, similarity += m.similaritySeconds, optimiser += m.optimiserSeconds;
            iterations += m.iterations, evaluations += m.evaluations;
            const PoseError reach = poseError(m.cameraToWorld, trackStart);
            const bool withinReach = (o.mapReachMm <= 0 || reach.position <= o.mapReachMm) &&
                                     (o.mapReachDegrees <= 0 || reach.degrees <= o.mapReachDegrees);
            if (m.converged && withinReach) {
                start = m.cameraToWorld;
                method.motionPrior = o.albedoPrior;
                if (!byMapBest || m.similarity > byMapBest->similarity) byMapBest = m;
            }
        }
        FrameRegistration r = registerFrame(mesh, frame, start, method);
        render += r.renderSeconds, similarity += r.similaritySeconds, optimiser += r.optimiserSeconds;
        iterations += r.iterations, evaluations += r.evaluations;
        if (!have || outranks(r, best)) best = r, have = true;
    }
    if (best.converged && byMapBest) {
        const PoseError apart = poseError(best.cameraToWorld, byMapBest->cameraToWorld);
        if ((o.mapAgreementMm > 0 && apart.position > o.mapAgreementMm) ||
            (o.mapAgreementDegrees > 0 && apart.degrees > o.mapAgreementDegrees))
            best.converged = false, best.mapDisagreed = true;
    }
    if (!best.converged && byMapBest && o.keepMapPose) {
        // Flagged either way; the estimate is the map's converged pose, with
        // the method's similarity there (an evaluation, no iterations).
        RegisterOptions at = options;
        at.maxIterations = 0;
        at.recheck = false;
        const FrameRegistration s = registerFrame(mesh, frame, byMapBest->cameraToWorld, at);
        render += s.renderSeconds, similarity += s.similaritySeconds, evaluations += s.evaluations;
        best.cameraToWorld = byMapBest->cameraToWorld;
        best.similarity = s.similarity;
        best.poseSd = byMapBest->poseSd;
        best.depthRange = s.depthRange;  // the kept pose's view
        best.noLumen = best.noLumen || s.noLumen;
        best.mapPoseKept = true;
    }
    if (best.noLumen && noLumenSearchCandidates(o) > 0) {
        // Facing the wall, shape fixes the pose weakly and the iterations
        // from the track stop in whatever valley they reach (on the CT
        // airway, poses up to 46 degrees off that the truth outscored): the
        // draws around the track's start, scored and refined as for a first
        // frame, reach the others. The frame stays flagged either way.
        InitialSearch search = o.noLumenSearch;
        search.candidates = noLumenSearchCandidates(o);
        const FrameRegistration w = registerInitial(mesh, frame, tracker.start(), options, search);
        render += w.renderSeconds, similarity += w.similaritySeconds, optimiser += w.optimiserSeconds;
        iterations += w.iterations, evaluations += w.evaluations;
        if (outranks(w, best)) {
            best = w;
            best.searched = true;
        }
    }
    best.renderSeconds = render, best.similaritySeconds = similarity, best.optimiserSeconds = optimiser;
    best.iterations = iterations, best.evaluations = evaluations;
    best.mapConverged = byMapBest.has_value();
    if (byMapBest) best.mapCameraToWorld = byMapBest->cameraToWorld;
    tracker.update(best);
    if (map && paintsAlbedoMap(best, o)) map->add(mesh, frame, best.cameraToWorld, o);
    return best;
}

int noLumenSearchCandidates(const RegisterOptions& o) noexcept {
    if (o.noLumenSearch.candidates >= 0) return o.noLumenSearch.candidates;
    return o.method == RegistrationMethod::PqSpace ? kNoLumenSearchCandidates : 0;
}

frames::Mat4 predictPose(const frames::Mat4& before, const frames::Mat4& last, double damping) noexcept {
    // Relative motion in the camera's frame: M = before^-1 * last = [R | t].
    const Mat3 Rb = rotationOf(before), Rl = rotationOf(last);
    const Mat3 R = Rb.transpose() * Rl;
    const Eigen::Vector3d t = Rb.transpose() * Eigen::Vector3d(last[0][3] - before[0][3], last[1][3] - before[1][3],
                                                               last[2][3] - before[2][3]);
    // Applied again after `last` (last * M: the same numbers, now in last's
    // axes), both parts scaled by the damping.
    const Eigen::AngleAxisd aa(R);
    const Eigen::Vector3d w = aa.axis() * aa.angle() * damping;
    const Eigen::Vector3d tl = t * damping;
    return perturbPose(last, {tl[0], tl[1], tl[2]}, {w[0], w[1], w[2]});
}

}  // namespace mucosa::registration
