// Hostile mesh files (found by fuzzing and review): each is refused with a typed error naming
// the file, quickly, before Assimp sees it.
#include <chrono>
#include <fstream>
#include <future>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/io.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

void writeText(const std::filesystem::path& p, const std::string& s) {
    std::ofstream(p, std::ios::binary) << s;
}

// Loads `path` on a detached thread; fails (without blocking) if it takes more
// than 20 s, which only a hang would. Returns the InputError's message.
std::string expectInputErrorWithin20s(const std::filesystem::path& path, const mesh::LoadOptions& options = {}) {
    auto done = std::make_shared<std::promise<std::string>>();
    std::future<std::string> result = done->get_future();
    std::thread([done, path, options] {
        try {
            mesh::load(path, options);
            done->set_value("no error");
        } catch (const InputError& e) {
            done->set_value(std::string("InputError: ") + e.what());
        } catch (const std::exception& e) {
            done->set_value(std::string("other: ") + e.what());
        }
    }).detach();
    if (result.wait_for(std::chrono::seconds(20)) != std::future_status::ready) {
        ADD_FAILURE() << path << " did not return within 20 s";
        return {};
    }
    const std::string what = result.get();
    EXPECT_EQ(what.rfind("InputError: ", 0), 0u) << what;
    EXPECT_NE(what.find(path.filename().string()), std::string::npos) << what;
    return what;
}

TEST(HostileImport, PlyWithoutEndHeaderIsRefused) {
    TempDir dir;
    // 36 bytes: Assimp 5.2.5 scans forever on this (and ignores SIGTERM).
    writeText(dir / "hang.ply", std::string("ply\nformat binary_little_endian 1.0\n"));
    const std::string what = expectInputErrorWithin20s(dir / "hang.ply");
    EXPECT_NE(what.find("end_header"), std::string::npos) << what;
}

TEST(HostileImport, PlyBytesUnderAnotherExtensionAreCheckedAsPly) {
    TempDir dir;
    // Assimp falls back to the PLY reader by content: found by fuzz_mesh_gltf.
    for (const char* name : {"hang.gltf", "hang.obj", "hang.stl"}) {
        writeText(dir / name, std::string("ply\nformat binary_little_endian 1.0\n"));
        const std::string what = expectInputErrorWithin20s(dir / name);
        EXPECT_NE(what.find("end_header"), std::string::npos) << name << ": " << what;
    }
}

TEST(HostileImport, TruncatedPlyThatCrashesAssimpIsRefused) {
    TempDir dir;
    // 47 bytes: segfaults inside Assimp's BaseImporter::ReadFile.
    const std::string bytes("ply\nformat binary_little_endian 1.0\nelemen1?\0\0\0", 47);
    ASSERT_EQ(bytes.size(), 47u);
    writeText(dir / "crash.ply", bytes);
    const std::string what = expectInputErrorWithin20s(dir / "crash.ply");
    EXPECT_NE(what.find("end_header"), std::string::npos) << what;
}

TEST(HostileImport, CoordinatesInfiniteAfterScalingAreRefused) {
    TempDir dir;
    // 1e36 is a finite float; in metres x1000 it is not.
    writeText(dir / "big.obj", "v 0 0 0\nv 1e36 0 0\nv 0 1 0\nf 1 2 3\n");
    mesh::LoadOptions metres;
    metres.unit = mesh::Unit::Metres;
    const std::string what = expectInputErrorWithin20s(dir / "big.obj", metres);
    EXPECT_NE(what.find("non-finite"), std::string::npos) << what;
    // Kept and counted when asked to.
    mesh::LoadOptions keep = metres;
    keep.allowNonFinite = true;
    EXPECT_EQ(mesh::load(dir / "big.obj", keep).positions.size(), 3u);
}

TEST(HostileImport, ValidPlyStillLoads) {
    TempDir dir;
    writeText(dir / "ok.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n10 0 0\n0 10 0\n3 0 1 2\n");
    const Mesh m = mesh::load(dir / "ok.ply");
    EXPECT_EQ(m.positions.size(), 3u);
    EXPECT_EQ(m.indices.size(), 3u);
}

// A one-triangle glTF whose buffer is the file `bufferUri` (36 bytes of
// positions), with accessor count and buffer byteLength as given.
std::string triangleGltf(const std::string& bufferUri, int byteLength = 36, long long count = 3, bool withView = true) {
    const std::string accessorView = withView ? R"("bufferView": 0, )" : "";
    return R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "buffers": [{"uri": ")" +
           bufferUri + R"(", "byteLength": )" + std::to_string(byteLength) + R"(}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}],
  "accessors": [{)" +
           accessorView + R"("componentType": 5126, "count": )" + std::to_string(count) +
           R"(, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}]})";
}

void writeTriangleBuffer(const std::filesystem::path& p) {
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(xyz), sizeof xyz);
}

TEST(HostileImport, GltfBufferInsideTheFolderLoads) {
    TempDir dir;
    std::filesystem::create_directories(dir / "bin");
    writeTriangleBuffer(dir / "bin" / "tri.bin");
    writeText(dir / "ok.gltf", triangleGltf("bin/tri.bin"));
    const Mesh m = mesh::load(dir / "ok.gltf");
    ASSERT_EQ(m.positions.size(), 3u);
    EXPECT_FLOAT_EQ(m.positions[1][0], 1000.0f);  // metres -> mm
}

TEST(HostileImport, GltfUrisOutsideTheModelsFolderAreNeverRead) {
    TempDir dir;
    std::filesystem::create_directories(dir / "model");
    std::filesystem::create_directories(dir / "secret");
    writeTriangleBuffer(dir / "secret" / "tri.bin");  // a well-formed buffer, outside
    std::filesystem::create_symlink(dir / "secret" / "tri.bin", dir / "model" / "link.bin");
    const std::string outside = (dir / "secret" / "tri.bin").string();
    for (const std::string& uri : {std::string("../../../../../../etc/passwd"), std::string("../secret/tri.bin"),
                                   std::string("%2e%2e/secret/tri.bin"), outside, "file://" + outside,
                                   std::string("link.bin"), std::string("http://127.0.0.1:9/tri.bin")}) {
        writeText(dir / "model" / "evil.gltf", triangleGltf(uri));
        const std::string what = expectInputErrorWithin20s(dir / "model" / "evil.gltf");
        EXPECT_NE(what.find("not a file inside the model's folder"), std::string::npos) << uri << ": " << what;
    }
}

TEST(HostileImport, GltfSizesBeyondTheirDataAreRefusedBeforeAllocating) {
    TempDir dir;
    writeTriangleBuffer(dir / "tri.bin");
    // A buffer longer than its file.
    writeText(dir / "a.gltf", triangleGltf("tri.bin", 1 << 30));
    EXPECT_NE(expectInputErrorWithin20s(dir / "a.gltf").find("only 36 back it"), std::string::npos);
    // An accessor of 2^32 elements in a 36-byte view (the issue's 64 GiB request).
    writeText(dir / "b.gltf", triangleGltf("tri.bin", 36, 1ll << 32));
    EXPECT_NE(expectInputErrorWithin20s(dir / "b.gltf").find("buffer view"), std::string::npos);
    // An accessor with no data at all: zero-filled, bounded by the file's size.
    writeText(dir / "c.gltf", triangleGltf("tri.bin", 36, 1ll << 32, false));
    EXPECT_NE(expectInputErrorWithin20s(dir / "c.gltf").find("accessors without data"), std::string::npos);
    // Negative and fractional counts.
    writeText(dir / "d.gltf", triangleGltf("tri.bin", 36, -3));
    EXPECT_NE(expectInputErrorWithin20s(dir / "d.gltf").find("accessors[0].count' in"), std::string::npos);
}

TEST(HostileImport, GlbChunkLongerThanTheFileIsRefused) {
    TempDir dir;
    // 79 bytes whose JSON chunk claims 0xfa000248 bytes (Assimp: 4.7 GB RSS).
    std::string glb(
        "glTF\x02\0\0\0\x4f\0\0\0\x48\x02\0\xfa"
        "JSON",
        20);
    glb += std::string(79 - glb.size(), ' ');
    ASSERT_EQ(glb.size(), 79u);
    writeText(dir / "huge.glb", glb);
    const std::string what = expectInputErrorWithin20s(dir / "huge.glb");
    EXPECT_NE(what.find("chunk 0 declares 4194304584 bytes"), std::string::npos) << what;
}

TEST(HostileImport, ObjMaterialLibraryOutsideTheFolderIsNotRead) {
    TempDir dir;
    std::filesystem::create_directories(dir / "model");
    writeText(dir / "outside.mtl", "newmtl stolen\nKd 1 0 0\n");
    writeText(dir / "model" / "m.obj", "mtllib ../outside.mtl\nusemtl stolen\nv 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\n");
    mesh::LoadInfo info;
    const Mesh m = mesh::load(dir / "model" / "m.obj", {}, &info);
    EXPECT_EQ(m.indices.size(), 3u);
    bool warned = false;
    for (const std::string& w : info.warnings) warned = warned || w.find("outside.mtl") != std::string::npos;
    EXPECT_TRUE(warned) << "no warning about the refused material library";
}

TEST(HostileImport, ParserLimitsComeFromTheOptions) {
    TempDir dir;
    writeText(dir / "ok.obj", "v 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\n");
    mesh::LoadOptions tight;
    tight.importMemoryBytes = 1;  // no mesh fits in one byte (resident set or result)
    const std::string what = expectInputErrorWithin20s(dir / "ok.obj", tight);
    EXPECT_NE(what.find("than 1 B"), std::string::npos) << what;
    mesh::LoadOptions inProcess;
    inProcess.isolate = false;
    EXPECT_EQ(mesh::load(dir / "ok.obj", inProcess).indices.size(), 3u);
}

// A 274-byte ASCII PLY that the fuzz campaign found: its header is complete,
// so it passes every check, and Assimp 5.2.5 then spins on it (30 s of CPU
// and counting). The sandbox ends it at the CPU limit with one error.
TEST(HostileImport, AssimpHangIsEndedByTheSandbox) {
    TempDir dir;
    const std::filesystem::path hang =
        std::filesystem::path(MUCOSA_SOURCE_DIR) / "fuzz/corpus/mesh/assimp_ply_hang.ply";
    ASSERT_TRUE(std::filesystem::exists(hang));
    std::filesystem::copy_file(hang, dir / "hang.ply");
    mesh::LoadOptions quick;
    quick.importSeconds = 1;  // wall deadline 2x + 5 s
    const auto start = std::chrono::steady_clock::now();
    const std::string what = expectInputErrorWithin20s(dir / "hang.ply", quick);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_TRUE(what.find("s of CPU") != std::string::npos || what.find("did not finish") != std::string::npos) << what;
    EXPECT_LT(seconds, 10.0);
}

}  // namespace
}  // namespace mucosa::test
