// mucosa render: frames of a scene, headless (EGL), to PNG files.
#include <memory>

#include <mucosa/dataset/ground_truth.hpp>

#include "render_sequence.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

void addRenderCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<RenderArgs>();
    CLI::App* c = app.add_subcommand("render", "Render a scene headless (EGL) to PNG: one frame or a camera path");
    c->footer(
        "Examples:\n  mucosa render -o frame.png\n  mucosa render scene.json -o fly.png --frames 120 "
        "--mode vertex-phong --size 1280x1024");
    addSceneOptions(c, a->scene);
    c->add_option("-o,--output", a->output,
                  "Output PNG; with --frames N: out_0000.png ... out_<N-1>.png and out.render.json, the settings they "
                  "were made with")
        ->required();
    c->add_option("--frames", a->frames, "Frames along the camera path [the scene's frames, 1]")
        ->check(wholeNumber(1, 1000000));
    c->add_flag("--overwrite", a->overwrite,
                "Start over: render every frame again, even those on disk (default: keep them and resume, if "
                "OUT.render.json says they were made with the same settings)");
    c->add_flag("--reference", a->reference, "Use the C++ reference renderer (no OpenGL; slow)");
    c->add_option("--outputs", a->outputs,
                  "What each frame writes, comma-separated: rgb, linear, highlight, depth, normals, mask, uv, face, "
                  "flow, branch (ground "
                  "truth beside "
                  "each frame, and OUT.frames.json: poses, intrinsics, every file's encoding and unit; "
                  "docs/datasets.md) [the scene's \"outputs\", else rgb]");
    c->add_option("--depth-png-scale", a->depthScaleMm,
                  "Millimetres per unit of the 16-bit depth PNG [0.01: up to 655 mm]");
    c->add_option("--rgb-bits", a->rgbBits,
                  "Bits per channel of the colour frames' PNGs: 8, or 16 (drawn into a float target and rounded "
                  "once) [8]")
        ->check(CLI::IsMember({8, 16}));
    c->add_option("--exr-compression", a->exrCompression,
                  "Lossless compression of the float EXR outputs: zip (smallest on smooth data), piz, zips, rle, or "
                  "none (fastest to write; docs/datasets.md) [zip]");
    c->add_option("--lens", a->lens,
                  "Render through this lens: a lens JSON (pinhole, fisheye, omnidirectional) or OCamCalib's "
                  "calib_results.txt, at its size (docs/datasets.md, \"Lens models\"), or equidistant[:DEG], a "
                  "bronchoscope's fisheye at the frame's size whose image circle spans DEG degrees [camera.fov_deg] "
                  "[the scene's camera.lens, else the pinhole of camera.fov_deg]");
    c->callback([a, &g] { renderSequence(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(40, addRenderCommand);

}  // namespace mucosa::cli
