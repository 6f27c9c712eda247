#pragma once
#include <string_view>

#include <mucosa/version.hpp>

namespace mucosa {
// The library's version ("0.1.0"), as recorded in sidecars and reports.
std::string_view version() noexcept;
}  // namespace mucosa
