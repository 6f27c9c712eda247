#include "video_encode.hpp"

#include <stdexcept>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

namespace mucosa::test {

namespace {

void check(int r, const char* what) {
    if (r < 0) {
        char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
        av_strerror(r, buf, sizeof buf);
        throw std::runtime_error(std::string(what) + ": " + buf);
    }
}

}  // namespace

void encodeVideo(const std::filesystem::path& path, const std::vector<image::Image8>& frames, const VideoEncoding& e) {
    if (frames.empty()) throw std::runtime_error("no frames");
    const int W = frames[0].width(), H = frames[0].height();
    const AVCodec* codec = avcodec_find_encoder_by_name(e.codec.c_str());
    if (!codec) throw std::runtime_error("no encoder " + e.codec);
    AVFormatContext* fmt = nullptr;
    check(avformat_alloc_output_context2(&fmt, nullptr, nullptr, path.c_str()), "output context");
    AVStream* st = avformat_new_stream(fmt, nullptr);
    AVCodecContext* c = avcodec_alloc_context3(codec);
    const bool rgb = e.codec == "ffv1";
    const bool jpeg = e.codec == "mjpeg";
    c->width = W;
    c->height = H;
    c->time_base = AVRational{1, e.fps};
    c->framerate = AVRational{e.fps, 1};
    c->gop_size = 10;
    c->pix_fmt = rgb ? AV_PIX_FMT_BGR0 : (jpeg ? AV_PIX_FMT_YUVJ420P : AV_PIX_FMT_YUV420P);
    const bool full = jpeg || e.fullRange;
    if (!rgb) {
        c->color_range = full ? AVCOL_RANGE_JPEG : AVCOL_RANGE_MPEG;
        c->colorspace = e.bt709 ? AVCOL_SPC_BT709 : AVCOL_SPC_SMPTE170M;
    }
    if (jpeg || e.codec == "mpeg4") {
        c->flags |= AV_CODEC_FLAG_QSCALE;
        c->global_quality = FF_QP2LAMBDA * e.quality;
    }
    if (e.codec == "libx264") {
        av_opt_set(c->priv_data, "preset", "veryfast", 0);
        av_opt_set_int(c->priv_data, "crf", e.quality, 0);
    }
    if (fmt->oformat->flags & AVFMT_GLOBALHEADER) c->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    check(avcodec_open2(c, codec, nullptr), "open encoder");
    check(avcodec_parameters_from_context(st->codecpar, c), "stream parameters");
    st->time_base = c->time_base;
    check(avio_open(&fmt->pb, path.c_str(), AVIO_FLAG_WRITE), "open file");
    check(avformat_write_header(fmt, nullptr), "header");

    SwsContext* sws = sws_getContext(W, H, AV_PIX_FMT_RGB24, W, H, c->pix_fmt,
                                     SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INP, nullptr, nullptr, nullptr);
    if (!rgb)
        sws_setColorspaceDetails(sws, sws_getCoefficients(SWS_CS_DEFAULT), 1,
                                 sws_getCoefficients(e.bt709 ? SWS_CS_ITU709 : SWS_CS_ITU601), full ? 1 : 0, 0, 1 << 16,
                                 1 << 16);
    AVFrame* f = av_frame_alloc();
    f->format = c->pix_fmt;
    f->width = W;
    f->height = H;
    check(av_frame_get_buffer(f, 0), "frame buffer");
    AVPacket* pkt = av_packet_alloc();
    auto drain = [&] {
        for (;;) {
            const int r = avcodec_receive_packet(c, pkt);
            if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) return;
            check(r, "encode");
            pkt->duration = 1;  // one frame: MP4's edit list otherwise ends at the last frame's start, dropping it
            av_packet_rescale_ts(pkt, c->time_base, st->time_base);
            pkt->stream_index = st->index;
            check(av_interleaved_write_frame(fmt, pkt), "write");
        }
    };
    for (std::size_t i = 0; i < frames.size(); ++i) {
        if (frames[i].width() != W || frames[i].height() != H || frames[i].channels() != 3)
            throw std::runtime_error("frames differ in size");
        check(av_frame_make_writable(f), "writable");
        const std::uint8_t* src[4] = {frames[i].data(), nullptr, nullptr, nullptr};
        const int srcStride[4] = {3 * W, 0, 0, 0};
        sws_scale(sws, src, srcStride, 0, H, f->data, f->linesize);
        f->pts = static_cast<std::int64_t>(i);
        check(avcodec_send_frame(c, f), "send frame");
        drain();
    }
    check(avcodec_send_frame(c, nullptr), "flush");
    drain();
    check(av_write_trailer(fmt), "trailer");
    av_packet_free(&pkt);
    av_frame_free(&f);
    sws_freeContext(sws);
    avcodec_free_context(&c);
    avio_closep(&fmt->pb);
    avformat_free_context(fmt);
}

}  // namespace mucosa::test
