#pragma once
// Measuring specular aliasing: how much the highlights of a still
// view flicker under sub-pixel camera jitter, and how far a one-sample frame
// is from a supersampled one, with specular anti-aliasing off and on.
#include <array>
#include <cstddef>

#include <mucosa/render/offscreen.hpp>

namespace mucosa::render {

// The projection shifted by (dx, dy) pixels (sub-pixel jitter).
shading::Mat4 jitteredProjection(const shading::Mat4& projection, float dx, float dy, int width, int height);

struct AliasingOptions {
    int jitterFrames = 16;      // frames of sub-pixel jitter (R2 sequence, offsets in [-0.5, 0.5) px)
    int supersample = 4;        // the reference: supersample^2 samples per pixel (box filter), anti-aliasing off
    int specularThreshold = 4;  // mask: pixels whose mean specular (0..255) exceeds this with AA off or on
};

struct AliasingReport {
    // Index 0: anti-aliasing off, 1: on.
    // Mean |s_t - s_(t-1)| over masked pixels and consecutive frames, where s
    // is the specular part (the frame minus the diffuse mode's frame), 0..255.
    std::array<double, 2> flicker{};
    std::array<double, 2> specularMean{};  // mean s over the mask (energy check)
    // RMS difference (0..255, RGB, masked pixels) of the un-jittered frame
    // from the supersampled reference (anti-aliasing off, supersample^2 spp).
    std::array<double, 2> errorVsReference{};
    std::size_t maskPixels = 0;
};

// Measures `frame` (its mode, with specularAA set off and on in turn).
AliasingReport measureSpecularAliasing(OffscreenSession& session, const shading::FrameSetup& frame,
                                       const AliasingOptions& options = {});

}  // namespace mucosa::render
