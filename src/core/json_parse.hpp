#pragma once
// One JSON parse for every input file the library reads: any failure of the
// parser becomes one InputError naming the file, so no raw library message
// reaches the user. Malformed text (a trailing comma, a missing quote) is
// reported where it is, "<file>:<line>:<column>: JSON: <what>" (Error's
// positioned form); numbers that overflow a double such as 1e999, which
// nlohmann reports as out_of_range, not parse_error, as "JSON in <file>: a
// number is out of range ...".
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>

namespace mucosa::detail {

// The 1-based line and column of the byte at 0-based `offset` in `text` (an
// offset past the end: just after the last character). Columns count UTF-8
// characters, not bytes, as editors do.
inline std::pair<int, int> lineAndColumn(std::string_view text, std::size_t offset) {
    const std::string_view before = text.substr(0, std::min(offset, text.size()));
    const std::size_t lastNewline = before.rfind('\n');
    const std::size_t lineStart = lastNewline == std::string_view::npos ? 0 : lastNewline + 1;
    const auto line = 1 + std::count(before.begin(), before.end(), '\n');
    const auto column = 1 + std::count_if(before.begin() + static_cast<std::ptrdiff_t>(lineStart), before.end(),
                                          [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; });
    constexpr auto kMax = std::numeric_limits<int>::max();
    return {static_cast<int>(std::min<std::ptrdiff_t>(line, kMax)),
            static_cast<int>(std::min<std::ptrdiff_t>(column, kMax))};
}

// What nlohmann says went wrong, without its "[json.exception.parse_error.101]
// parse error at line 1, column 2: " prefix (its own position, which this
// file's caller reports from the byte offset), control characters from the
// input shown as '?'.
inline std::string parseErrorWhat(const nlohmann::json::parse_error& e) {
    std::string what = e.what();
    const std::size_t at = what.find("parse error");
    const std::size_t colon = at == std::string::npos ? std::string::npos : what.find(": ", at);
    if (colon != std::string::npos) what.erase(0, colon + 2);
    for (char& c : what)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return what;
}

inline nlohmann::json parseJsonFile(const std::string& text, const std::string& file) {
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
        // e.byte: 1-based index of the last character read (size + 1 at the end).
        const auto [line, column] = lineAndColumn(text, e.byte > 0 ? e.byte - 1 : 0);
        throw InputError("JSON", file, line, column, parseErrorWhat(e));
    } catch (const nlohmann::json::out_of_range&) {
        throw InputError("JSON", file, "a number is out of range (larger than a double can hold)");
    } catch (const nlohmann::json::exception& e) {
        throw InputError("JSON", file, e.what());
    }
}

// A JSON value as a whole number in [lo, hi]: integers of either sign and
// whole-valued floats (3.0) are taken; fractions, out-of-range values (no
// wrap, no truncation: 4294967297 is not 1) and other types are refused with
// an InputError naming the field and the file.
template <class Int>
Int wholeNumber(const nlohmann::json& j, const std::string& field, const std::string& file,
                Int lo = std::numeric_limits<Int>::min(), Int hi = std::numeric_limits<Int>::max()) {
    auto outOfRange = [&](const std::string& shown) {
        return InputError("field '" + field + "'", file, fmt::format("{} is out of range [{}, {}]", shown, lo, hi));
    };
    if (j.is_number_unsigned()) {
        const auto v = j.get<std::uint64_t>();
        if (std::cmp_less(v, lo) || std::cmp_greater(v, hi)) throw outOfRange(std::to_string(v));
        return static_cast<Int>(v);
    }
    if (j.is_number_integer()) {
        const auto v = j.get<std::int64_t>();
        if (std::cmp_less(v, lo) || std::cmp_greater(v, hi)) throw outOfRange(std::to_string(v));
        return static_cast<Int>(v);
    }
    if (j.is_number_float()) {
        const double d = j.get<double>();
        if (!std::isfinite(d) || d != std::floor(d))
            throw InputError("field '" + field + "'", file, fmt::format("must be a whole number, not {}", d));
        if (d < static_cast<double>(lo) || d > static_cast<double>(hi)) throw outOfRange(fmt::format("{}", d));
        return static_cast<Int>(d);
    }
    throw InputError("field '" + field + "'", file, std::string("must be a whole number, not ") + j.type_name());
}

}  // namespace mucosa::detail
