#pragma once
// One JSON parse for every input file the library reads: any failure of the
// parser (malformed text, and numbers that overflow a double such as 1e999,
// which nlohmann reports as out_of_range, not parse_error) becomes one
// InputError naming the file, so no raw library message reaches the user.
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>

namespace mucosa::detail {

inline nlohmann::json parseJsonFile(const std::string& text, const std::string& file) {
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
        throw InputError("JSON", file, fmt::format("parse error at byte {}", e.byte));
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
