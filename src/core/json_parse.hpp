#pragma once
// One JSON parse for every input file the library reads: any failure of the
// parser (malformed text, and numbers that overflow a double such as 1e999,
// which nlohmann reports as out_of_range, not parse_error) becomes one
// InputError naming the file, so no raw library message reaches the user.
#include <string>

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

}  // namespace mucosa::detail
