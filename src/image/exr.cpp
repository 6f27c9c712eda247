#include <mucosa/image/exr.hpp>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <algorithm>
#include <string>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

namespace mucosa::image {

namespace {
std::vector<std::string> channelNames(int channels) {
    switch (channels) {
        case 1:
            return {"Y"};
        case 2:
            return {"Y", "A"};
        case 3:
            return {"R", "G", "B"};
        default:
            return {"R", "G", "B", "A"};
    }
}
}  // namespace

void writeExr(const std::filesystem::path& path, const ImageF& img) {
    if (img.empty()) throw InputError("image", path.string(), "is empty");
    AtomicFile file(path);  // reserves the temporary name; OpenEXR writes it
    try {
        Imf::Header header(img.width(), img.height());
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::FrameBuffer fb;
        const auto names = channelNames(img.channels());
        const std::size_t xs = sizeof(float) * static_cast<std::size_t>(img.channels());
        for (int c = 0; c < img.channels(); ++c) {
            header.channels().insert(names[static_cast<std::size_t>(c)], Imf::Channel(Imf::FLOAT));
            fb.insert(names[static_cast<std::size_t>(c)],
                      Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(img.data()) + c), xs,
                                 xs * static_cast<std::size_t>(img.width())));
        }
        Imf::OutputFile out(file.temporaryPath().c_str(), header);
        out.setFrameBuffer(fb);
        out.writePixels(img.height());
    } catch (const std::exception& e) {
        throw IoError("EXR output", path.string(), e.what());
    }
    file.commit();
}

ImageF readExr(const std::filesystem::path& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError("input", path.string(), "no such file");
    try {
        Imf::InputFile in(path.c_str());
        const Imath::Box2i dw = in.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        std::vector<std::string> present;
        for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it)
            present.emplace_back(it.name());
        int channels = 1;
        std::vector<std::string> names;
        auto has = [&](const char* n) { return std::find(present.begin(), present.end(), n) != present.end(); };
        if (has("R") && has("G") && has("B")) {
            names = has("A") ? std::vector<std::string>{"R", "G", "B", "A"} : std::vector<std::string>{"R", "G", "B"};
        } else if (has("Y")) {
            names = {"Y"};
        } else if (!present.empty()) {
            names = {present.front()};
        } else {
            throw InputError("EXR", path.string(), "has no channels");
        }
        channels = static_cast<int>(names.size());
        ImageF img(w, h, channels);
        Imf::FrameBuffer fb;
        const std::size_t xs = sizeof(float) * static_cast<std::size_t>(channels);
        char* base = reinterpret_cast<char*>(img.data()) -
                     (static_cast<std::ptrdiff_t>(dw.min.x) + static_cast<std::ptrdiff_t>(dw.min.y) * w) *
                         static_cast<std::ptrdiff_t>(xs);
        for (int c = 0; c < channels; ++c)
            fb.insert(names[static_cast<std::size_t>(c)],
                      Imf::Slice(Imf::FLOAT, base + sizeof(float) * static_cast<std::size_t>(c), xs,
                                 xs * static_cast<std::size_t>(w)));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        return img;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError("EXR", path.string(), e.what());
    }
}

}  // namespace mucosa::image
