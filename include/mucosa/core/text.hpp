#pragma once
// Small text helpers shared by the modules that write documents (SVG plots,
// HTML reports).
#include <string>
#include <string_view>

namespace mucosa {

// `s` with <, >, & and " replaced by their XML entities: safe as SVG/HTML
// text and as a double-quoted attribute value.
std::string escapeXml(std::string_view s);

}  // namespace mucosa
