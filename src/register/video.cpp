// Video decoding with FFmpeg: demux (libavformat), decode (libavcodec), and
// convert to full-range RGB24 (libswscale) with the stream's own YUV matrix
// and range, so that a frame reads as the scope's processor encoded it.
#include <mucosa/register/video.hpp>

#include <cmath>
#include <cstring>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::registration {

namespace {

std::string avError(int code) {
    char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
    av_strerror(code, buf, sizeof buf);
    return buf;
}

struct FormatCloser {
    void operator()(AVFormatContext* f) const noexcept { avformat_close_input(&f); }
};
struct CodecFreer {
    void operator()(AVCodecContext* c) const noexcept { avcodec_free_context(&c); }
};
struct PacketFreer {
    void operator()(AVPacket* p) const noexcept { av_packet_free(&p); }
};
struct FrameFreer {
    void operator()(AVFrame* f) const noexcept { av_frame_free(&f); }
};
struct ScaleFreer {
    void operator()(SwsContext* s) const noexcept { sws_freeContext(s); }
};

// The deprecated full-range "J" formats as their plain twin plus the range.
AVPixelFormat plainFormat(AVPixelFormat f, bool& fullRange) {
    switch (f) {
        case AV_PIX_FMT_YUVJ420P:
            fullRange = true;
            return AV_PIX_FMT_YUV420P;
        case AV_PIX_FMT_YUVJ422P:
            fullRange = true;
            return AV_PIX_FMT_YUV422P;
        case AV_PIX_FMT_YUVJ444P:
            fullRange = true;
            return AV_PIX_FMT_YUV444P;
        case AV_PIX_FMT_YUVJ440P:
            fullRange = true;
            return AV_PIX_FMT_YUV440P;
        case AV_PIX_FMT_YUVJ411P:
            fullRange = true;
            return AV_PIX_FMT_YUV411P;
        default:
            return f;
    }
}

}  // namespace

struct VideoReader::Impl {
    std::string file;
    VideoInfo info;
    std::unique_ptr<AVFormatContext, FormatCloser> format;
    std::unique_ptr<AVCodecContext, CodecFreer> codec;
    std::unique_ptr<AVPacket, PacketFreer> packet{av_packet_alloc()};
    std::unique_ptr<AVFrame, FrameFreer> frame{av_frame_alloc()};
    std::unique_ptr<SwsContext, ScaleFreer> scale;
    int stream = -1;
    bool draining = false, ended = false;
    std::int64_t read = 0;
    // The conversion is set up for this source (format, size, matrix, range).
    int scaleFormat = -1, scaleSpace = -1, scaleRange = -1;

    [[noreturn]] void fail(const std::string& why) const { throw InputError("video", file, why); }

    // The next decoded frame into `frame`, or false at the end of the stream.
    bool decode() {
        for (;;) {
            const int r = avcodec_receive_frame(codec.get(), frame.get());
            if (r == 0) return true;
            if (r == AVERROR_EOF) return false;
            if (r != AVERROR(EAGAIN)) fail(fmt::format("frame {} cannot be decoded: {}", read, avError(r)));
            if (draining) return false;
            // The decoder wants input: the next packet of our stream, or the flush at the end.
            int got = 0;
            while ((got = av_read_frame(format.get(), packet.get())) >= 0 && packet->stream_index != stream)
                av_packet_unref(packet.get());
            if (got == AVERROR_EOF) {
                draining = true;
                avcodec_send_packet(codec.get(), nullptr);
                continue;
            }
            if (got < 0) fail(fmt::format("reading after frame {} failed: {}", read, avError(got)));
            const int s = avcodec_send_packet(codec.get(), packet.get());
            av_packet_unref(packet.get());
            if (s < 0 && s != AVERROR(EAGAIN)) fail(fmt::format("frame {} cannot be decoded: {}", read, avError(s)));
        }
    }

    void convert(image::Image8& rgb) {
        const AVFrame& f = *frame;
        if (f.width != info.width || f.height != info.height)
            fail(fmt::format("frame {} is {}x{}, but the video started at {}x{}", read, f.width, f.height, info.width,
                             info.height));
        bool full = f.color_range == AVCOL_RANGE_JPEG;
        const AVPixelFormat src = plainFormat(static_cast<AVPixelFormat>(f.format), full);
        // The matrix the stream names; unnamed: BT.709 for HD, BT.601 below
        // (what players assume).
        int space = SWS_CS_ITU601;
        switch (f.colorspace) {
            case AVCOL_SPC_BT709:
                space = SWS_CS_ITU709;
                break;
            case AVCOL_SPC_FCC:
                space = SWS_CS_FCC;
                break;
            case AVCOL_SPC_SMPTE240M:
                space = SWS_CS_SMPTE240M;
                break;
            case AVCOL_SPC_BT2020_NCL:
            case AVCOL_SPC_BT2020_CL:
                space = SWS_CS_BT2020;
                break;
            case AVCOL_SPC_UNSPECIFIED:
                space = f.height >= 720 ? SWS_CS_ITU709 : SWS_CS_ITU601;
                break;
            default:
                space = SWS_CS_ITU601;
                break;
        }
        if (!scale || scaleFormat != src || scaleSpace != space || scaleRange != int(full)) {
            scale.reset(sws_getContext(f.width, f.height, src, f.width, f.height, AV_PIX_FMT_RGB24,
                                       SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, nullptr, nullptr, nullptr));
            if (!scale)
                fail(fmt::format("its pixel format {} cannot be converted to RGB",
                                 av_get_pix_fmt_name(static_cast<AVPixelFormat>(f.format))));
            const int* coeffs = sws_getCoefficients(space);
            // Source range as the stream says, destination full-range RGB;
            // brightness 0, contrast and saturation 1 (16.16 fixed point).
            sws_setColorspaceDetails(scale.get(), coeffs, full ? 1 : 0, sws_getCoefficients(SWS_CS_DEFAULT), 1, 0,
                                     1 << 16, 1 << 16);
            scaleFormat = src, scaleSpace = space, scaleRange = int(full);
        }
        if (rgb.width() != f.width || rgb.height() != f.height || rgb.channels() != 3)
            rgb = image::Image8(f.width, f.height, 3);
        std::uint8_t* dst[4] = {rgb.data(), nullptr, nullptr, nullptr};
        const int dstStride[4] = {3 * f.width, 0, 0, 0};
        sws_scale(scale.get(), f.data, f.linesize, 0, f.height, dst, dstStride);
    }
};

VideoReader::VideoReader(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.file = path.string();
    av_log_set_level(AV_LOG_QUIET);  // errors are ours to report, in one line
    if (!m.packet || !m.frame) throw std::bad_alloc();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw IoError("video", m.file, "does not exist or is not a file");
    AVFormatContext* raw = nullptr;
    if (const int r = avformat_open_input(&raw, m.file.c_str(), nullptr, nullptr); r < 0)
        m.fail("is not a video FFmpeg can read (" + avError(r) + ")");
    m.format.reset(raw);
    if (const int r = avformat_find_stream_info(m.format.get(), nullptr); r < 0)
        m.fail("its streams cannot be read (" + avError(r) + ")");
    const AVCodec* decoder = nullptr;
    m.stream = av_find_best_stream(m.format.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &decoder, 0);
    if (m.stream == AVERROR_STREAM_NOT_FOUND) m.fail("has no video stream");
    if (m.stream < 0 || !decoder) m.fail("its video codec has no decoder in this FFmpeg");
    const AVStream* st = m.format->streams[m.stream];
    m.codec.reset(avcodec_alloc_context3(decoder));
    if (!m.codec) throw std::bad_alloc();
    if (const int r = avcodec_parameters_to_context(m.codec.get(), st->codecpar); r < 0)
        m.fail("its codec parameters are invalid (" + avError(r) + ")");
    m.codec->thread_count = 0;  // FFmpeg picks
    if (const int r = avcodec_open2(m.codec.get(), decoder, nullptr); r < 0)
        m.fail(fmt::format("its {} decoder cannot be opened ({})", decoder->name, avError(r)));
    m.info.width = st->codecpar->width;
    m.info.height = st->codecpar->height;
    m.info.codec = decoder->name;
    if (m.info.width <= 0 || m.info.height <= 0 || m.info.width > 16384 || m.info.height > 16384)
        m.fail(fmt::format("its frame size {}x{} is not a video's (1..16384)", m.info.width, m.info.height));
    // One decoded frame, its RGB copy and the decoder's reference frames.
    requireMemory(saturatingMul(static_cast<std::uint64_t>(m.info.width) * m.info.height, 3 * 20),
                  "decoding " + m.file);
    if (st->avg_frame_rate.num > 0 && st->avg_frame_rate.den > 0) m.info.fps = av_q2d(st->avg_frame_rate);
    if (st->nb_frames > 0)
        m.info.frameCount = st->nb_frames;
    else if (m.info.fps > 0 && m.format->duration > 0)
        m.info.frameCount = std::llround(static_cast<double>(m.format->duration) / AV_TIME_BASE * m.info.fps);
}

VideoReader::~VideoReader() = default;

const VideoInfo& VideoReader::info() const noexcept {
    return impl_->info;
}

bool VideoReader::next(image::Image8& rgb) {
    Impl& m = *impl_;
    if (m.ended) return false;
    if (!m.decode()) {
        m.ended = true;
        return false;
    }
    m.convert(rgb);
    av_frame_unref(m.frame.get());
    ++m.read;
    return true;
}

std::int64_t VideoReader::framesRead() const noexcept {
    return impl_->read;
}

}  // namespace mucosa::registration
