// `mucosa study analyze` at the scale: 100 observers x 1,000 Likert
// ratings (100,000 rows). Reading the CSV, the statistics, and the whole report.
//   bench_study                      Google Benchmark timings + peak memory
//   bench_study --make-csv FILE      write the data set (to time the CLI itself)
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <mucosa/study/analysis.hpp>

namespace {

namespace fs = std::filesystem;
using namespace mucosa::study;

constexpr int kObservers = 100, kRatingsPerObserver = 1000;

// Observer o rates 200 images per category; score ~ category + observer bias + noise.
void writeCsv(const fs::path& path) {
    std::mt19937_64 rng(2006);
    std::normal_distribution<double> noise(0, 1), bias(0, 0.4);
    std::ofstream out(path);
    out << "observer,group,category,image_id,score\n";
    for (int o = 0; o < kObservers; ++o) {
        const double b = bias(rng);
        const char* group = o < 70 ? "naive" : "expert";
        for (int i = 0; i < kRatingsPerObserver; ++i) {
            const int c = 1 + i % 5;
            const int s = std::clamp(static_cast<int>(std::lround(1 + 0.8 * c + b + noise(rng))), 1, 5);
            out << fmt::format("O{:03d},{},{},img{:04d},{}\n", o, group, c, i, s);
        }
    }
}

const fs::path& dataset() {
    static const fs::path p = [] {
        fs::path f = fs::temp_directory_path() / "mucosa_bench_study_100x1000.csv";
        writeCsv(f);
        return f;
    }();
    return p;
}

void BM_ReadCsv(benchmark::State& state) {
    for (auto _ : state) benchmark::DoNotOptimize(readRatingsCsv(dataset()));
    state.SetItemsProcessed(state.iterations() * kObservers * kRatingsPerObserver);
}

void BM_Analyze(benchmark::State& state) {
    StudyData d;
    d.ratings = readRatingsCsv(dataset());
    for (auto _ : state) benchmark::DoNotOptimize(analyze(d));
    state.SetItemsProcessed(state.iterations() * kObservers * kRatingsPerObserver);
}

// What `mucosa study analyze ratings.csv -o DIR` does: read, analyse, write the report.
void BM_AnalyzeEndToEnd(benchmark::State& state) {
    const fs::path dir = fs::temp_directory_path() / "mucosa_bench_study_report";
    for (auto _ : state) {
        StudyData d;
        d.ratings = readRatingsCsv(dataset());
        writeReport(analyze(d), dir, dataset().string());
    }
    fs::remove_all(dir);
    state.SetItemsProcessed(state.iterations() * kObservers * kRatingsPerObserver);
}

BENCHMARK(BM_ReadCsv)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Analyze)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AnalyzeEndToEnd)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
    if (argc == 3 && std::strcmp(argv[1], "--make-csv") == 0) {
        writeCsv(argv[2]);
        std::printf("wrote %s (%d observers x %d ratings)\n", argv[2], kObservers, kRatingsPerObserver);
        return 0;
    }
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    std::printf("peak resident memory: %.1f MiB\n", static_cast<double>(ru.ru_maxrss) / 1024.0);
    std::filesystem::remove(dataset());
    return 0;
}
