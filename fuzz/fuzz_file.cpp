// One harness per file parser, chosen at compile time (fuzz/CMakeLists.txt):
// the input is written to a file named FUZZ_FILE (its extension selects the
// format where the parser looks at it) and read with FUZZ_READ(path).
#include <cstddef>
#include <cstdint>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/brdf.hpp>
#include <mucosa/study/analysis.hpp>
#include <mucosa/study/plan.hpp>

#include "fuzz_support.hpp"

#ifndef FUZZ_FILE
#error "FUZZ_FILE (the scratch file's name) must be defined"
#endif

namespace {

[[maybe_unused]] void readMesh(const std::filesystem::path& p) {
    mucosa::mesh::LoadInfo info;
    // Assimp runs isolated; its limits here end a hang well inside libFuzzer's
    // -timeout=20 (5 s CPU, 15 s wall), so what the fuzzer sees is the
    // sandbox's verdict, and a child's crash is an InputError, not a finding.
    mucosa::mesh::LoadOptions options;
    options.importSeconds = 5;
    options.importMemoryBytes = 1ull << 30;
    const auto m = mucosa::mesh::load(p, options, &info);
    mucosa::mesh::validateIndices(m, p.string());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = mucosa::fuzz::writeInput(data, size, FUZZ_FILE);
    return mucosa::fuzz::guarded([&] { (void)(FUZZ_READ(path)); });
}
