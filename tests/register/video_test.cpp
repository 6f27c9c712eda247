// Video files through FFmpeg: exact frames from a lossless codec, the YUV
// range and matrix honoured for lossy ones, and bad files refused in one line.
#include <cmath>
#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/register/video.hpp>

#include "test_support.hpp"
#include "video_encode.hpp"

using namespace mucosa;
namespace fs = std::filesystem;

namespace {

// Frames with detail in every channel: a gradient, a moving square, noise.
std::vector<image::Image8> testFrames(int n, int w, int h) {
    std::vector<image::Image8> out;
    std::uint32_t s = 12345;
    for (int i = 0; i < n; ++i) {
        image::Image8 f(w, h, 3);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                s = s * 1664525u + 1013904223u;
                const bool square = x >= 4 * i && x < 4 * i + 10 && y >= 8 && y < 18;
                f.at(x, y, 0) = static_cast<std::uint8_t>(square ? 250 : (x * 255) / (w - 1));
                f.at(x, y, 1) = static_cast<std::uint8_t>((y * 255) / (h - 1));
                f.at(x, y, 2) = static_cast<std::uint8_t>(s >> 24);
            }
        out.push_back(std::move(f));
    }
    return out;
}

// Flat patches of known colours, 16 x 16 each (chroma subsampling cannot
// blur their centres): dark, bright, and saturated tissue tones.
const std::array<std::array<int, 3>, 4> kPatches{{{20, 20, 20}, {235, 235, 235}, {200, 80, 60}, {90, 40, 50}}};
image::Image8 patchFrame() {
    image::Image8 f(64, 16, 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c) f.at(x, y, c) = static_cast<std::uint8_t>(kPatches[x / 16][c]);
    return f;
}

}  // namespace

TEST(Video, LosslessFramesComeBackExactlyInOrder) {
    test::TempDir dir;
    const auto frames = testFrames(12, 48, 32);
    test::encodeVideo(dir / "v.mkv", frames, {});
    registration::VideoReader r(dir / "v.mkv");
    EXPECT_EQ(r.info().width, 48);
    EXPECT_EQ(r.info().height, 32);
    EXPECT_NEAR(r.info().fps, 25.0, 1e-9);
    EXPECT_EQ(r.info().codec, "ffv1");
    EXPECT_NEAR(static_cast<double>(r.info().frameCount), 12.0, 1.0);  // the container's estimate
    image::Image8 got;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        ASSERT_TRUE(r.next(got)) << i;
        ASSERT_EQ(got.width(), 48);
        ASSERT_EQ(got.height(), 32);
        std::size_t differ = 0;
        for (std::size_t k = 0; k < got.size(); ++k) differ += got.data()[k] != frames[i].data()[k];
        EXPECT_EQ(differ, 0u) << "frame " << i;
    }
    EXPECT_FALSE(r.next(got));
    EXPECT_FALSE(r.next(got));  // and stays at the end
    EXPECT_EQ(r.framesRead(), 12);
}

TEST(Video, YuvRangeAndMatrixAreHonoured) {
    // The same colours through limited-range BT.601 (MPEG-4 Part 2),
    // limited-range BT.709 (H.264 in MP4) and full-range JPEG YUV (MJPEG in
    // AVI): read back within a few levels. Ignoring the range moves black by
    // 16 levels and white by 20; the wrong matrix moves the saturated red by 9.
    test::TempDir dir;
    const std::vector<image::Image8> frames(3, patchFrame());
    struct Case {
        std::string file;
        test::VideoEncoding e;
    };
    std::vector<Case> cases;
    cases.push_back({"bt601.mp4", {"mpeg4", 25, false, false, 1}});
    cases.push_back({"bt709.mp4", {"libx264", 25, false, true, 0}});
    cases.push_back({"jpeg.avi", {"mjpeg", 25, true, false, 1}});
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file);
        test::encodeVideo(dir / c.file, frames, c.e);
        registration::VideoReader r(dir / c.file);
        image::Image8 got;
        int n = 0;
        while (r.next(got)) {
            ++n;
            for (std::size_t p = 0; p < kPatches.size(); ++p)
                for (int c3 = 0; c3 < 3; ++c3) {
                    const int v = got.at(static_cast<int>(16 * p + 8), 8, c3);
                    EXPECT_NEAR(v, kPatches[p][static_cast<std::size_t>(c3)], 3) << "patch " << p << " channel " << c3;
                }
        }
        EXPECT_EQ(n, 3);
    }
}

TEST(Video, BadFilesAreRefusedNamingTheFile) {
    test::TempDir dir;
    auto refused = [&](const fs::path& p, const std::string& needle) {
        SCOPED_TRACE(p.string());
        try {
            registration::VideoReader r(p);
            image::Image8 f;
            while (r.next(f)) {
            }
            ADD_FAILURE() << "accepted";
        } catch (const Error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(p.filename().string()), std::string::npos) << what;
            EXPECT_NE(what.find(needle), std::string::npos) << what;
        }
    };
    refused(dir / "missing.mp4", "does not exist");
    std::ofstream(dir / "notes.mp4") << "not a video at all\n";
    refused(dir / "notes.mp4", "is not a video");
    std::ofstream(dir / "empty.mkv");
    refused(dir / "empty.mkv", "is not a video");
    // A PNG is an image FFmpeg reads as a one-frame video: that is fine. An
    // audio-only stream is not: a WAV header with no video.
    {
        std::ofstream w(dir / "audio.wav", std::ios::binary);
        const char hdr[] =
            "RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x01\x00\x40\x1f\x00\x00\x80\x3e\x00"
            "\x00\x02\x00\x10\x00"
            "data\x00\x00\x00\x00";
        w.write(hdr, sizeof hdr - 1);
    }
    refused(dir / "audio.wav", "has no video stream");
}

TEST(Video, ATruncatedFileEndsEarlyOrFailsInOneErrorNeverCrashes) {
    test::TempDir dir;
    const auto frames = testFrames(20, 48, 32);
    for (const std::string name : {"t.mkv", "t.avi"}) {
        SCOPED_TRACE(name);
        test::VideoEncoding e;
        if (name == "t.avi") e.codec = "mjpeg";
        test::encodeVideo(dir / name, frames, e);
        const std::string bytes = test::readBytes(dir / name);
        for (double keep : {0.3, 0.55, 0.8}) {
            const fs::path cut = dir / ("cut_" + name);
            std::ofstream(cut, std::ios::binary)
                .write(bytes.data(), static_cast<std::streamsize>(keep * static_cast<double>(bytes.size())));
            int n = 0;
            try {
                registration::VideoReader r(cut);
                image::Image8 f;
                while (r.next(f)) {
                    ++n;
                    ASSERT_EQ(f.width(), 48);
                }
            } catch (const Error& err) {
                EXPECT_NE(std::string(err.what()).find("cut_"), std::string::npos) << err.what();
            }
            EXPECT_LT(n, 20) << keep;
        }
    }
}
