// Fit time against the number of back-projected samples: the joint
// robust solve plus the texture atlas, on synthetic samples drawn from a known
// rho and delta with 5 % highlight outliers. Back-projection (one depth pass
// per frame) is not included: it scales with frames x pixels, not samples.
#include <benchmark/benchmark.h>

#include <random>

#include <mucosa/fit/fit.hpp>

namespace {

std::vector<mucosa::fit::Sample> makeSamples(std::size_t n) {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    std::normal_distribution<float> noise(0.f, 0.004f);
    std::vector<mucosa::fit::Sample> s(n);
    for (std::size_t i = 0; i < n; ++i) {
        auto& x = s[i];
        x.u = uni(rng);
        x.v = uni(rng);
        x.gamma = 0.15f + 0.85f * uni(rng);
        x.z = 3.f + 40.f * uni(rng);
        x.frame = static_cast<std::uint32_t>(i % 16);
        const float g = x.gamma, r = (x.z - 3.f) / 40.f;
        const float rho = 0.25f + g * (0.9f + g * (-0.3f + g * 0.15f));
        const float delta = 1.f + r * (-0.9f + r * (0.45f - r * 0.08f));
        const float a = 0.4f + 0.3f * x.u;
        const float spec = uni(rng) < 0.05f ? 0.5f : 0.f;
        for (int k = 0; k < 3; ++k) x.I[k] = a * rho * delta + spec + noise(rng);
    }
    return s;
}

void FitSolveAndTexture(benchmark::State& state) {
    const auto samples = makeSamples(static_cast<std::size_t>(state.range(0)));
    mucosa::fit::FitOptions o;
    o.textureSize = 1024;
    for (auto _ : state) {
        mucosa::fit::FitResult r;
        r.brdf = mucosa::fit::solveBrdf(samples, o, &r);
        mucosa::fit::buildTexture(samples, r.brdf, o, r);
        benchmark::DoNotOptimize(r.texture.data());
    }
    state.counters["s/Msample"] =
        benchmark::Counter(static_cast<double>(state.range(0)) * static_cast<double>(state.iterations()) / 1e6,
                           benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The two parts on their own (where the time goes).
void FitSolveOnly(benchmark::State& state) {
    const auto samples = makeSamples(static_cast<std::size_t>(state.range(0)));
    mucosa::fit::FitOptions o;
    int iterations = 0;
    for (auto _ : state) {
        mucosa::fit::FitResult r;
        r.brdf = mucosa::fit::solveBrdf(samples, o, &r);
        iterations = r.solverIterations;
        benchmark::DoNotOptimize(r.brdf.c.data());
    }
    state.counters["iterations"] = iterations;
}

void FitTextureOnly(benchmark::State& state) {
    const auto samples = makeSamples(static_cast<std::size_t>(state.range(0)));
    mucosa::fit::FitOptions o;
    o.textureSize = 1024;
    mucosa::fit::FitResult base;
    base.brdf = mucosa::fit::solveBrdf(samples, o, &base);
    for (auto _ : state) {
        mucosa::fit::FitResult r = base;
        mucosa::fit::buildTexture(samples, r.brdf, o, r);
        benchmark::DoNotOptimize(r.texture.data());
    }
}

}  // namespace

BENCHMARK(FitSolveOnly)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(FitTextureOnly)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(FitSolveAndTexture)
    ->Arg(100000)
    ->Arg(1000000)
    ->Arg(4000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

BENCHMARK_MAIN();
