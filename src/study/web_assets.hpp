#pragma once
// The study page (src/study/web/*), embedded at build time by embed_web.cmake
// so `mucosa study serve` runs from any folder with no files beside it.
#include <cstddef>
#include <string>
#include <vector>

namespace mucosa::study::detail {

struct WebAsset {
    std::string path;  // "index.html", "app.js", "style.css"
    const char* mime;
    const char* data;
    std::size_t size;
};

const std::vector<WebAsset>& webAssets();

}  // namespace mucosa::study::detail
