#pragma once
// Test videos written with FFmpeg's own encoders (libavformat + libavcodec),
// so that the decoder is tested on files made here, not downloaded.
#include <filesystem>
#include <string>
#include <vector>

#include <mucosa/image/image.hpp>

namespace mucosa::test {

struct VideoEncoding {
    std::string codec = "ffv1";  // ffv1 (lossless RGB), mjpeg (full-range YUV), libx264, mpeg4
    int fps = 25;
    bool fullRange = false;  // tag the YUV as full range (mjpeg: always)
    bool bt709 = false;      // tag the YUV matrix as BT.709 (else BT.601)
    int quality = 2;         // qscale for mjpeg / mpeg4; crf for libx264 (low: near lossless)
};

// Encodes RGB frames (all of one size) into `path`; the container follows the
// extension (.mkv, .avi, .mp4). Throws std::runtime_error on failure.
void encodeVideo(const std::filesystem::path& path, const std::vector<image::Image8>& frames,
                 const VideoEncoding& e = {});

}  // namespace mucosa::test
