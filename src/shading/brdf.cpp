#include <mucosa/shading/brdf.hpp>

#include <cmath>

#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "core/json_parse.hpp"

namespace mucosa::shading {

using json = nlohmann::json;

json toJson(const BrdfParams& p) {
    return json{{"c", p.c}, {"d", p.d}, {"zmin", p.zmin}, {"zmax", p.zmax}, {"samples", p.samples}, {"rms", p.rms}};
}

BrdfParams brdfFromJson(const json& j, const std::string& file) {
    BrdfParams p;
    auto numbers = [&](const char* key, auto& out) {
        if (!j.contains(key) || !j[key].is_array() || j[key].size() != out.size())
            throw InputError(std::string("field '") + key + "'", file,
                             "must be an array of " + std::to_string(out.size()) + " numbers");
        for (std::size_t i = 0; i < out.size(); ++i) {
            if (!j[key][i].is_number()) throw InputError(std::string("field '") + key + "'", file, "must hold numbers");
            out[i] = j[key][i].get<double>();
            if (!std::isfinite(out[i])) throw InputError(std::string("field '") + key + "'", file, "must be finite");
        }
    };
    auto number = [&](const char* key, double& out) {
        if (!j.contains(key) || !j[key].is_number())
            throw InputError(std::string("field '") + key + "'", file, "must be a number");
        out = j[key].get<double>();
    };
    if (!j.is_object()) throw InputError("brdf", file, "must be a JSON object");
    numbers("c", p.c);
    numbers("d", p.d);
    number("zmin", p.zmin);
    number("zmax", p.zmax);
    if (!(p.zmax > p.zmin)) throw InputError("field 'zmax'", file, "must be greater than zmin");
    if (j.contains("samples") && j["samples"].is_number_unsigned()) p.samples = j["samples"].get<std::size_t>();
    if (j.contains("rms") && j["rms"].is_number()) p.rms = j["rms"].get<double>();
    return p;
}

BrdfParams readBrdf(const std::filesystem::path& path) {
    return brdfFromJson(detail::parseJsonFile(readTextFile(path), path.string()), path.string());
}

}  // namespace mucosa::shading
