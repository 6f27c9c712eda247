// Tangent frames on 250k / 1M / 4M triangles (the phantom, subdivided 1:4)
// next to Assimp's aiProcess_CalcTangentSpace on the very same mesh, and the
// phantom's generation time.
//   bench_mesh --benchmark_filter=Tangents
//   bench_mesh --benchmark_filter=Phantom
//   bench_mesh --benchmark_filter=Load
#include <map>
#include <memory>

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <benchmark/benchmark.h>
#include <assimp/Importer.hpp>

#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/tangents.hpp>

namespace {

using namespace mucosa::mesh;

// Splits every triangle in four at its edge midpoints (attributes interpolated).
Mesh subdivide(const Mesh& m) {
    Mesh out = m;
    out.tangents.clear();
    out.indices.clear();
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
        const auto key = std::minmax(a, b);
        auto [it, inserted] =
            mid.try_emplace({key.first, key.second}, static_cast<std::uint32_t>(out.positions.size()));
        if (inserted) {
            Vec3 p, n;
            for (int k = 0; k < 3; ++k) p[k] = 0.5f * (m.positions[a][k] + m.positions[b][k]);
            for (int k = 0; k < 3; ++k) n[k] = m.normals[a][k] + m.normals[b][k];
            const float l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (float& c : n) c /= l;
            out.positions.push_back(p);
            out.normals.push_back(n);
            out.uvs.push_back({0.5f * (m.uvs[a][0] + m.uvs[b][0]), 0.5f * (m.uvs[a][1] + m.uvs[b][1])});
        }
        return it->second;
    };
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        const std::uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
        const std::uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
        out.indices.insert(out.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
    }
    return out;
}

// The phantom at ~250k triangles, then 1M and 4M by subdivision.
const Mesh& benchMesh(int level) {
    static std::map<int, Mesh> cache;
    auto it = cache.find(level);
    if (it != cache.end()) return it->second;
    if (level == 0) {
        PhantomParams p;
        p.resolution = 1.3;
        return cache[0] = makePhantom(p).mesh;
    }
    return cache[level] = subdivide(benchMesh(level - 1));
}

void BM_TangentsMucosa(benchmark::State& state) {
    Mesh m = benchMesh(static_cast<int>(state.range(0)));
    const int threads = static_cast<int>(state.range(1));
    for (auto _ : state) {
        computeTangents(m, threads);
        benchmark::DoNotOptimize(m.tangents.data());
    }
    state.counters["triangles"] = static_cast<double>(m.triangleCount());
    state.counters["Mtri/s"] = benchmark::Counter(static_cast<double>(m.triangleCount()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

void BM_TangentsAssimp(benchmark::State& state) {
    const Mesh& m = benchMesh(static_cast<int>(state.range(0)));
    // The same mesh handed to Assimp as a binary PLY (vertices shared, as ours).
    const std::string file = "/tmp/mucosa-bench-mesh-" + std::to_string(state.range(0)) + ".ply";
    Mesh noTangents = m;
    noTangents.tangents.clear();
    writePly(noTangents, file);
    Assimp::Importer importer;
    const aiScene* scene = importer.ReadFile(file, 0);
    if (!scene || scene->mNumMeshes != 1) {
        state.SkipWithError("Assimp could not read the benchmark mesh");
        return;
    }
    aiMesh* am = scene->mMeshes[0];
    for (auto _ : state) {
        state.PauseTiming();
        delete[] am->mTangents;
        delete[] am->mBitangents;
        am->mTangents = am->mBitangents = nullptr;
        state.ResumeTiming();
        importer.ApplyPostProcessing(aiProcess_CalcTangentSpace);
        benchmark::DoNotOptimize(am->mTangents);
    }
    state.counters["triangles"] = static_cast<double>(am->mNumFaces);
    state.counters["vertices"] = static_cast<double>(am->mNumVertices);
    state.counters["Mtri/s"] =
        benchmark::Counter(static_cast<double>(am->mNumFaces) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
    std::remove(file.c_str());
}

// Import of the phantom as binary PLY, isolated (Assimp in a forked child with
// limits, the result piped back and validated: the default) next to Assimp in
// the calling process: the price of surviving hostile files.
void BM_Load(benchmark::State& state) {
    const Mesh& m = benchMesh(static_cast<int>(state.range(0)));
    const std::string file = "/tmp/mucosa-bench-load-" + std::to_string(state.range(0)) + ".ply";
    writePly(m, file);
    LoadOptions options;
    options.isolate = state.range(1) != 0;
    std::size_t triangles = 0;
    for (auto _ : state) {
        const Mesh loaded = load(file, options);
        triangles = loaded.triangleCount();
    }
    state.counters["triangles"] = static_cast<double>(triangles);
    state.SetLabel(options.isolate ? "isolated" : "in-process");
    std::remove(file.c_str());
}

void BM_PhantomDefault(benchmark::State& state) {
    std::size_t triangles = 0;
    for (auto _ : state) {
        const Phantom p = makePhantom(PhantomParams{});
        triangles = p.mesh.triangleCount();
    }
    state.counters["triangles"] = static_cast<double>(triangles);
}

}  // namespace

// range(0): 0 = 250k, 1 = 1M, 2 = 4M triangles; range(1): threads (0 = all).
BENCHMARK(BM_TangentsMucosa)->ArgsProduct({{0, 1, 2}, {1, 0}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TangentsAssimp)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
// range(0): mesh size as above; range(1): 1 = isolated (default), 0 = in-process.
BENCHMARK(BM_Load)->ArgsProduct({{0, 1}, {1, 0}})->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_PhantomDefault)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

BENCHMARK_MAIN();
