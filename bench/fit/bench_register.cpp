// Registration on a rendered bronchoscopy with known poses: accuracy (median
// and p95 position and orientation error, losses), the first frame's capture
// range, and seconds per frame split into renders, similarity and optimiser,
// for the pq-space method and the intensity baseline in the same run.
//   bench_register [frames=60] [size=320] [working widths, coarse to fine...]
// The airway, frames and lighting are those of tests/register/register_scene.hpp:
// a curved airway with rings and a fold, vessels over blotches, glints,
// Gaussian noise, exposure +-30 % frame to frame, 8-bit gamma-2.2 frames.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include <mucosa/register/register.hpp>

#include "register_scene.hpp"

using namespace mucosa;

namespace {

double quantile(std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

// What the sensor delivers: 8-bit values with gamma 2.2, decoded back to linear.
image::ImageF through8bit(const image::ImageF& f, image::Image8& saturated) {
    image::ImageF o = f;
    saturated = image::Image8(f.width(), f.height(), 1);
    for (int y = 0; y < f.height(); ++y)
        for (int x = 0; x < f.width(); ++x) {
            bool sat = false;
            for (int c = 0; c < 3; ++c) {
                const double v = std::round(255.0 * std::pow(std::clamp(double(f.at(x, y, c)), 0.0, 1.0), 1 / 2.2));
                sat = sat || v >= 250;
                o.at(x, y, c) = static_cast<float>(std::pow(v / 255.0, 2.2));
            }
            saturated.at(x, y) = sat ? 1 : 0;
        }
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    const int frames = argc > 1 ? std::atoi(argv[1]) : 60;
    const int size = argc > 2 ? std::atoi(argv[2]) : 320;
    if (frames < 2 || frames > 90 || size < 64 || size > 1024) {
        std::fprintf(stderr, "usage: bench_register [frames 2..90] [size 64..1024]\n");
        return 2;
    }
    // MUCOSA_PREDICTION: the tracker's constant-velocity factor (default 1).
    const double prediction = std::getenv("MUCOSA_PREDICTION") ? std::atof(std::getenv("MUCOSA_PREDICTION")) : 1.0;
    std::vector<int> levels = registration::RegisterOptions{}.levels;
    if (argc > 3) levels.clear();
    for (int i = 3; i < argc; ++i) levels.push_back(std::atoi(argv[i]));
    const test::RegisterScene scene = test::makeRegisterScene(frames);
    frames::Intrinsics K;
    K.width = K.height = size;
    K.fx = K.fy = 0.5625 * size;  // 83 degrees across
    K.cx = K.cy = (size - 1) / 2.0;
    std::printf("airway: %zu triangles (video rendered from %zu); %d frames %dx%d, 0.6 mm and ~2 deg per frame\n",
                scene.mesh.triangleCount(), scene.truth.triangleCount(), frames, size, size);
    std::vector<registration::VideoFrame> pqFrames, ncFrames;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> gain(0.7, 1.3);
    std::vector<image::ImageF> linear(static_cast<std::size_t>(frames));
    std::vector<image::Image8> sat(static_cast<std::size_t>(frames));
    for (int i = 0; i < frames; ++i) {
        test::VideoOptions vo;
        vo.gain = gain(rng);
        vo.seed = static_cast<unsigned>(100 + i);
        linear[static_cast<std::size_t>(i)] =
            through8bit(test::renderVideoFrame(scene.truth, K, scene.poses[static_cast<std::size_t>(i)], vo, 0),
                        sat[static_cast<std::size_t>(i)]);
    }

    for (registration::RegistrationMethod method :
         {registration::RegistrationMethod::PqSpace, registration::RegistrationMethod::Intensity}) {
        registration::RegisterOptions o;
        o.method = method;
        o.levels = levels;
        // Tracking from a first pose 1.5 mm and 3 degrees off.
        const frames::Mat4 pose = registration::perturbPose(scene.poses[0], {0.9, -0.9, 0.7}, {0.03, -0.03, 0.02});
        std::vector<double> mm, deg;
        double render = 0, similarity = 0, optimiser = 0, wall = 0, renders = 0;
        int converged = 0, losses = 0, lostFor = 0;
        registration::Tracker tracker(pose, prediction);
        for (int i = 0; i < frames; ++i) {
            const auto t0 = std::chrono::steady_clock::now();
            const registration::VideoFrame vf = registration::prepareFrame(linear[static_cast<std::size_t>(i)],
                                                                           &sat[static_cast<std::size_t>(i)], K, o);
            const registration::FrameRegistration r = registration::registerTracked(scene.mesh, vf, tracker, o);
            wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            render += r.renderSeconds, similarity += r.similaritySeconds, optimiser += r.optimiserSeconds;
            renders += r.evaluations;
            converged += r.converged;
            const registration::PoseError e =
                registration::poseError(r.cameraToWorld, scene.poses[static_cast<std::size_t>(i)]);
            mm.push_back(e.position);
            deg.push_back(e.degrees);
            // A loss: error above 5 mm or 10 degrees for more than 10 frames.
            lostFor = (e.position > 5 || e.degrees > 10) ? lostFor + 1 : 0;
            if (lostFor == 11) ++losses;
        }
        const double n = frames;
        std::printf(
            "%-9s position median %.2f mm p95 %.2f mm | orientation median %.2f deg p95 %.2f deg | %d/%d converged, "
            "%d losses | %.2f s/frame (renders %.2f, similarity %.2f, optimiser %.2f; %.0f renders)\n",
            registration::methodName(method), quantile(mm, 0.5), quantile(mm, 0.95), quantile(deg, 0.5),
            quantile(deg, 0.95), converged, frames, losses, wall / n, render / n, similarity / n, optimiser / n,
            renders / n);
    }

    // Capture range: the first frame alone from initial errors of 2, 5, 10 mm
    // (with 5, 10, 20 degrees), 6 random directions each; success = within
    // 1 mm and 2 degrees.
    std::mt19937 dir(3);
    std::normal_distribution<double> g(0, 1);
    // Each method from one start (registerFrame), then with the initial
    // search (registerInitial, what mucosa register does for the first frame).
    // MUCOSA_SEARCH="candidates refine radius_mm degrees" overrides the search's defaults.
    registration::InitialSearch is;
    if (const char* e = std::getenv("MUCOSA_SEARCH"))
        std::sscanf(e, "%d %d %lf %lf", &is.candidates, &is.refine, &is.radiusMm, &is.degrees);
    for (bool search : {false, true})
        for (registration::RegistrationMethod method :
             {registration::RegistrationMethod::PqSpace, registration::RegistrationMethod::Intensity}) {
            registration::RegisterOptions o;
            o.method = method;
            o.levels = levels;
            const registration::VideoFrame vf = registration::prepareFrame(linear[0], &sat[0], K, o);
            std::printf("%-9s capture%s:", registration::methodName(method), search ? " with the initial search" : "");
            double seconds = 0;
            int runs = 0;
            for (const auto& [emm, edeg] : {std::pair{2.0, 5.0}, std::pair{5.0, 10.0}, std::pair{10.0, 20.0}}) {
                int ok = 0;
                const int tries = 6;
                for (int t = 0; t < tries; ++t) {
                    frames::Vec3d a{g(dir), g(dir), g(dir)}, b{g(dir), g(dir), g(dir)};
                    const double na = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
                    const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
                    for (int k = 0; k < 3; ++k) a[k] *= emm / na, b[k] *= edeg * M_PI / 180 / nb;
                    const frames::Mat4 start = registration::perturbPose(scene.poses[0], a, b);
                    const auto t0 = std::chrono::steady_clock::now();
                    const registration::FrameRegistration r =
                        search ? registration::registerInitial(scene.mesh, vf, start, o, is)
                               : registration::registerFrame(scene.mesh, vf, start, o);
                    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                    ++runs;
                    const registration::PoseError e = registration::poseError(r.cameraToWorld, scene.poses[0]);
                    ok += e.position < 1 && e.degrees < 2;
                }
                std::printf(" %.0f mm/%.0f deg: %d/%d", emm, edeg, ok, tries);
            }
            std::printf(" (%.2f s each)\n", seconds / runs);
        }
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    std::printf("peak memory %.0f MB\n", static_cast<double>(ru.ru_maxrss) / 1024.0);
    return 0;
}
