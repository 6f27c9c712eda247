// The initial search: the first frame from a rough pose, by scoring draws
// around it at the coarsest level and registering the best fully
// (registerInitial); the tracker's search of a frame with no lumen in view
// runs it around the track.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>

#include "phases.hpp"

namespace mucosa::registration {

using detail::Clock;
using detail::Neighbourhood;
using detail::neighbourhood;
using detail::Objective;
using detail::outranks;
using detail::secondsSince;

FrameRegistration registerInitial(const mesh::Mesh& fullMesh, const VideoFrame& frame, const frames::Mat4& initial,
                                  const RegisterOptions& o, const InitialSearch& search) {
    if (frame.levels.empty()) throw InputError("frame", "registration", "has no levels");
    const auto start = Clock::now();
    // The candidates: the given pose first, then draws around it.
    std::vector<frames::Mat4> poses{initial};
    std::mt19937 rng(search.seed);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    while (static_cast<int>(poses.size()) < std::max(1, search.candidates)) {
        frames::Vec3d t{uni(rng), uni(rng), uni(rng)};
        if (t[0] * t[0] + t[1] * t[1] + t[2] * t[2] > 1) continue;  // uniform in the ball
        frames::Vec3d w{gauss(rng), gauss(rng), gauss(rng)};
        const double nw = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        const double angle = std::abs(uni(rng)) * search.degrees * M_PI / 180;
        for (int k = 0; k < 3; ++k) t[k] *= search.radiusMm, w[k] *= nw > 0 ? angle / nw : 0.0;
        poses.push_back(perturbPose(initial, t, w));
    }
    // Scored at the coarsest level, side by side.
    const Neighbourhood near = neighbourhood(fullMesh, frames::cameraCentre(initial), o.farMm + search.radiusMm, o);
    const mesh::Mesh& mesh = near.mesh;
    FrameRegistration total;
    std::vector<double> score(poses.size(), -2.0);
    {
        Objective obj(mesh, frame.levels.front(), near.options, total);
        if (obj.pixels.size() >= 50) {
            std::vector<FrameRegistration> timing(poses.size());
            tbb::task_arena arena(resolveThreads(o.threads));
            arena.execute([&] {
                tbb::parallel_for(std::size_t{0}, poses.size(), [&](std::size_t i) {
                    Objective local = obj;
                    local.stats = &timing[i];
                    local.differences(poses[i], &score[i]);
                });
            });
            for (const FrameRegistration& t : timing) {
                total.renderSeconds += t.renderSeconds / resolveThreads(o.threads);
                total.similaritySeconds += t.similaritySeconds / resolveThreads(o.threads);
                total.evaluations += t.evaluations;
            }
        }
    }
    std::vector<std::size_t> order(poses.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return score[a] > score[b]; });
    std::vector<std::size_t> starts{0};
    for (std::size_t i : order) {
        if (static_cast<int>(starts.size()) > std::max(0, search.refine)) break;
        if (i != 0) starts.push_back(i);
    }
    std::vector<FrameRegistration> refined;
    RegisterOptions full = o;
    full.recheck = true;
    // No motion or roll prior: the candidates are draws around a rough pose,
    // not a prediction of where the scope is, and a prior around each would
    // hold its refinement near the draw (the roll prior took the capture
    // test's worst orientation from 1.5 to 2.2 degrees).
    full.motionPrior = full.rollPrior = 0;
    for (std::size_t i : starts) {
        refined.push_back(registerFrame(fullMesh, frame, poses[i], full));
        const FrameRegistration& r = refined.back();
        total.renderSeconds += r.renderSeconds, total.similaritySeconds += r.similaritySeconds;
        total.iterations += r.iterations, total.evaluations += r.evaluations;
    }
    // The best: converged first, then the highest similarity; among results
    // within `tie` of it, the one nearest the given pose (what the user said
    // breaks what the frame cannot: one tracheal ring along scores the same).
    FrameRegistration best = refined.front();
    for (const FrameRegistration& r : refined)
        if (outranks(r, best)) best = r;
    auto distance = [&](const FrameRegistration& r) {
        const PoseError e = poseError(r.cameraToWorld, initial);
        return e.position / std::max(search.radiusMm, 1e-9) + e.degrees / std::max(search.degrees, 1e-9);
    };
    const double bestSimilarity = best.similarity;
    for (const FrameRegistration& r : refined)
        if (r.converged == best.converged && r.similarity >= bestSimilarity - search.tie &&
            distance(r) < distance(best))
            best = r;
    best.renderSeconds = total.renderSeconds, best.similaritySeconds = total.similaritySeconds;
    best.iterations = total.iterations, best.evaluations = total.evaluations;
    best.optimiserSeconds = std::max(0.0, secondsSince(start) - best.renderSeconds - best.similaritySeconds);
    return best;
}

}  // namespace mucosa::registration
