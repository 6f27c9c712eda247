// Noise throughput on one job, in one run, next to the peer noise libraries:
// a 4096 x 4096 map of fBm, 6 octaves, lacunarity 2, gain 0.5, 8 cycles
// across the map. "samples" are map texels (each sums 6 octaves); the
// `evals/s` counter counts single noise evaluations (texels x octaves).
#include <benchmark/benchmark.h>

#include <noise.h>

#define STB_PERLIN_IMPLEMENTATION
#include <stb_perlin.h>

#include <thread>
#include <vector>

#include <mucosa/noise/fractal.hpp>

namespace {

constexpr int kSize = 4096;
constexpr int kOctaves = 6;
constexpr double kFrequency = 8.0;

mucosa::noise::FractalParams job() {
    mucosa::noise::FractalParams p;
    p.frequency = kFrequency;
    p.octaves = kOctaves;
    p.lacunarity = 2.0;
    p.gain = 0.5;
    return p;
}

void setCounters(benchmark::State& state) {
    const double texels = static_cast<double>(kSize) * kSize * static_cast<double>(state.iterations());
    state.counters["Msamples/s"] = benchmark::Counter(texels / 1e6, benchmark::Counter::kIsRate);
    state.counters["Mevals/s"] = benchmark::Counter(texels * kOctaves / 1e6, benchmark::Counter::kIsRate);
}

void MucosaFastFloat(benchmark::State& state) {
    std::vector<float> out(static_cast<std::size_t>(kSize) * kSize);
    const auto p = job();
    for (auto _ : state) {
        mucosa::noise::fillFractal(p, out, kSize, kSize, {static_cast<int>(state.range(0))});
        benchmark::DoNotOptimize(out.data());
    }
    setCounters(state);
    state.SetLabel(mucosa::noise::fastPathIsa());
}

void MucosaFastDouble(benchmark::State& state) {
    std::vector<double> out(static_cast<std::size_t>(kSize) * kSize);
    const auto p = job();
    for (auto _ : state) {
        mucosa::noise::fillFractal(p, out, kSize, kSize, {static_cast<int>(state.range(0))});
        benchmark::DoNotOptimize(out.data());
    }
    setCounters(state);
    state.SetLabel(std::string(mucosa::noise::fastPathIsa()) + ", reference-exact");
}

// The plain reference: Perlin's Java algorithm per sample, one thread.
void MucosaScalarReference(benchmark::State& state) {
    std::vector<double> out(static_cast<std::size_t>(kSize) * kSize);
    const auto p = job();
    const auto& perm = mucosa::noise::Permutation::reference();
    for (auto _ : state) {
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x)
                out[static_cast<std::size_t>(y) * kSize + x] =
                    mucosa::noise::fractal(p, perm, static_cast<double>(x) / kSize, static_cast<double>(y) / kSize);
        benchmark::DoNotOptimize(out.data());
    }
    setCounters(state);
}

void LibnoisePerlin(benchmark::State& state) {
    noise::module::Perlin perlin;
    perlin.SetOctaveCount(kOctaves);
    perlin.SetFrequency(kFrequency);
    perlin.SetLacunarity(2.0);
    perlin.SetPersistence(0.5);
    perlin.SetNoiseQuality(noise::QUALITY_STD);
    std::vector<float> out(static_cast<std::size_t>(kSize) * kSize);
    for (auto _ : state) {
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x)
                out[static_cast<std::size_t>(y) * kSize + x] = static_cast<float>(
                    perlin.GetValue(static_cast<double>(x) / kSize, static_cast<double>(y) / kSize, 0.5));
        benchmark::DoNotOptimize(out.data());
    }
    setCounters(state);
}

void StbPerlinFbm(benchmark::State& state) {
    std::vector<float> out(static_cast<std::size_t>(kSize) * kSize);
    for (auto _ : state) {
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x)
                out[static_cast<std::size_t>(y) * kSize + x] =
                    stb_perlin_fbm_noise3(static_cast<float>(kFrequency * x / kSize),
                                          static_cast<float>(kFrequency * y / kSize), 0.5f, 2.0f, 0.5f, kOctaves);
        benchmark::DoNotOptimize(out.data());
    }
    setCounters(state);
}

}  // namespace

BENCHMARK(MucosaFastFloat)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(MucosaFastDouble)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(MucosaScalarReference)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(LibnoisePerlin)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(StbPerlinFbm)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

BENCHMARK_MAIN();
