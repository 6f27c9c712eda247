// The viewer opens a window under Xvfb (GLFW needs an X server), draws frames
// with its panels and closes; the screenshot shows the scene, not black.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include <mucosa/image/png.hpp>

#include "test_support.hpp"

namespace mucosa {
namespace {

TEST(RenderViewer, OpensUnderXvfbDrawsFramesAndCloses) {
    ASSERT_EQ(std::system("command -v xvfb-run >/dev/null 2>&1"), 0)
        << "xvfb-run is missing (apt-get install xvfb xauth)";
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube"})";
    // The default mode, and the procedural mode in object space without
    // anti-aliasing (the toggles the viewer's keys and panel set).
    for (const std::string extra : {"", " --mode procedural --noise-space object --specular-aa off"}) {
        const auto shot = dir / "view.png";
#ifdef MUCOSA_VIEWER_PRELOAD  // sanitizer builds: see tests/render/CMakeLists.txt
        const std::string preload = std::string("env LD_PRELOAD='") + MUCOSA_VIEWER_PRELOAD + "' ";
#else
        const std::string preload;
#endif
        const std::string cmd = "xvfb-run -a -s '-screen 0 1024x768x24' " + preload + "'" + std::string(MUCOSA_CLI) +
                                "' view '" + (dir / "tube.json").string() +
                                "' --window 640x480 --frames 4 --screenshot '" + shot.string() + "'" + extra + " > '" +
                                (dir / "log.txt").string() + "' 2>&1";
        const int status = std::system(cmd.c_str());
        ASSERT_EQ(status, 0) << extra << test::readBytes(dir / "log.txt");
        EXPECT_NE(test::readBytes(dir / "log.txt").find("4 frames"), std::string::npos)
            << test::readBytes(dir / "log.txt");
        const auto img = image::readPng(shot);
        ASSERT_EQ(img.pixels.width(), 640);
        // The right half (no panel) is the rendered tube: pink, not black.
        double sum = 0;
        for (int y = 0; y < img.pixels.height(); ++y)
            for (int x = 400; x < 640; ++x) sum += img.pixels.at(x, y, 0);
        EXPECT_GT(sum / (240.0 * img.pixels.height()), 40.0) << extra;
    }
}

}  // namespace
}  // namespace mucosa
