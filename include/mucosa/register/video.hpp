#pragma once
// Bronchoscopy video files, decoded with FFmpeg's libraries (libavformat,
// libavcodec, libswscale): any container and codec the system's FFmpeg reads
// (MP4/H.264, MKV, AVI/MJPEG, FFV1, ...), frame by frame, as 8-bit RGB.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <mucosa/image/image.hpp>

namespace mucosa::registration {

struct VideoInfo {
    int width = 0, height = 0;
    double fps = 0;                // average frame rate; 0 if the file does not say
    std::int64_t frameCount = -1;  // from the container or duration x rate; -1 unknown (an estimate)
    std::string codec;             // e.g. "h264"
};

class VideoReader {
public:
    // Opens the first video stream of `path`. Throws IoError for a file that
    // cannot be read and InputError (naming the file) for one that is not a
    // video FFmpeg can decode, or whose frames would not fit in memory.
    explicit VideoReader(const std::filesystem::path& path);
    ~VideoReader();
    VideoReader(const VideoReader&) = delete;
    VideoReader& operator=(const VideoReader&) = delete;

    const VideoInfo& info() const noexcept;

    // The next frame in display order as RGB, full range (the stream's YUV
    // range and matrix, BT.601 or BT.709, are honoured), or false at the end.
    // Throws InputError on a corrupt stream or a frame whose size changed.
    bool next(image::Image8& rgb);

    // Frames returned by next() so far.
    std::int64_t framesRead() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace mucosa::registration
