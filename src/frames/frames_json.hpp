#pragma once
// The JSON keys frames, camera and registration files share (frames.cpp).
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include <mucosa/frames/frames.hpp>

namespace mucosa::frames {

// `target` relative to `folder` ('/' separators), or absolute when it cannot be.
std::string relativePath(const std::filesystem::path& target, const std::filesystem::path& folder);

// {"width", "height", "fx", "fy", "cx", "cy"[, "k1", "k2"]}: k1, k2 when not 0.
nlohmann::json intrinsicsJson(const Intrinsics& K);

// "gamma" or "tone_curve", "vignetting" when not 0, "saturation" when not 1.
void writeResponse(nlohmann::json& j, const Response& response);

}  // namespace mucosa::frames
