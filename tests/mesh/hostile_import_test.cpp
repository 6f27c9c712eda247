// Hostile mesh files from issue 13: each is refused with a typed error naming
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

}  // namespace
}  // namespace mucosa::test
