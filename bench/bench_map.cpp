// `mucosa map --size 4096` split into its stages (noise / normals / PNG
// encode / write), median of 5 runs, on 1 and 2 threads; and, in the same run,
// the same map written by libpng at zlib level 6 (the usual way to write a
// PNG) for the size and time comparison. Usage: bench_map [size] [outdir]
#include <png.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <fmt/format.h>

#include <mucosa/image/png.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>

namespace {

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

std::vector<unsigned char> gPng;
void onWrite(png_structp, png_bytep d, png_size_t n) {
    gPng.insert(gPng.end(), d, d + n);
}
void onFlush(png_structp) {}

std::size_t libpngLevel6(const mucosa::image::Image8& img) {
    gPng.clear();
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_set_write_fn(png, nullptr, onWrite, onFlush);
    png_set_IHDR(png, info, static_cast<png_uint_32>(img.width()), static_cast<png_uint_32>(img.height()), 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 6);
    png_write_info(png, info);
    for (int y = 0; y < img.height(); ++y) png_write_row(png, img.row(y));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return gPng.size();
}

}  // namespace

int main(int argc, char** argv) {
    using namespace mucosa;
    const int size = argc > 1 ? std::atoi(argv[1]) : 4096;
    const std::filesystem::path dir = argc > 2 ? argv[2] : std::filesystem::temp_directory_path();
    reflectance::MapParams p;  // `mucosa map` defaults
    p.size = size;
    reflectance::MapOutputs out;
    out.map = dir / "bench_map.png";
    out.sidecar = false;

    std::printf("mucosa map --size %d (defaults: fBm %d octaves, %g cycles), median of 5 runs\n\n", size,
                p.noise.octaves, p.noise.frequency);
    std::printf("| threads | noise s | normals + PNG encode s | write s | total s | PNG bytes |\n");
    std::printf("|---|---|---|---|---|---|\n");
    std::uint64_t ourBytes = 0;
    for (int threads : {1, 2}) {
        std::vector<double> n, e, w, t;
        for (int i = 0; i < 5; ++i) {
            const auto r = reflectance::generateMap(p, out, threads);
            n.push_back(r.noiseSeconds);
            e.push_back(r.encodeSeconds);
            w.push_back(r.writeSeconds);
            t.push_back(r.noiseSeconds + r.encodeSeconds + r.writeSeconds);
            ourBytes = r.mapBytes;
        }
        std::printf("| %d | %.3f | %.3f | %.3f | %.3f | %llu |\n", threads, median(n), median(e), median(w), median(t),
                    static_cast<unsigned long long>(ourBytes));
    }

    const image::ImageF H = reflectance::heightField(p);
    const image::Image8 m = reflectance::encodeNormals8(H, p.strength, reflectance::Edges::Clamp);
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t zlibBytes = libpngLevel6(m);
    const double zlibSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("\nsame map through libpng, zlib level 6, 1 thread: %.3f s, %zu bytes\n", zlibSeconds, zlibBytes);
    std::printf("Mucosa's PNG / libpng zlib-6 size: %.3f\n", static_cast<double>(ourBytes) / zlibBytes);
    std::filesystem::remove(out.map);
    return 0;
}
