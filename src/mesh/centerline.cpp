#include <mucosa/mesh/centerline.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "core/json_parse.hpp"

namespace mucosa::mesh {

void writeCenterlineJson(const Centerline& c, const std::filesystem::path& path) {
    nlohmann::json j;
    j["units"] = "mm";
    j["axes"] = c.axes;
    j["branches"] = nlohmann::json::array();
    for (const CenterlineBranch& b : c.branches) {
        nlohmann::json points = nlohmann::json::array();
        for (const Vec3& p : b.points) points.push_back({p[0], p[1], p[2]});
        j["branches"].push_back({{"name", b.name},
                                 {"parent", b.parent},
                                 {"generation", b.generation},
                                 {"points", points},
                                 {"radii", b.radii}});
    }
    writeFileAtomic(path, j.dump(1) + "\n");
}

Centerline readCenterlineJson(const std::filesystem::path& path) {
    using nlohmann::json;
    const std::string name = path.string();
    const json j = mucosa::detail::parseJsonFile(readTextFile(path), name);
    auto fail = [&](const std::string& field, const std::string& why) -> InputError {
        return InputError("field '" + field + "'", name, why);
    };
    auto finiteFloat = [&](const json& v, const std::string& field) {
        if (!v.is_number()) throw fail(field, std::string("must be a number, not ") + v.type_name());
        const double d = v.get<double>();
        if (!std::isfinite(d) || std::abs(d) > 3.0e38) throw fail(field, fmt::format("{} is not a finite float", d));
        return static_cast<float>(d);
    };
    if (!j.is_object()) throw InputError("centerline JSON", name, "must be a JSON object");
    Centerline c;
    if (j.contains("axes")) {
        if (!j["axes"].is_string()) throw fail("axes", "must be a string");
        c.axes = j["axes"].get<std::string>();
    }
    if (!j.contains("branches") || !j["branches"].is_array()) throw fail("branches", "must be an array");
    const json& branches = j["branches"];
    for (std::size_t i = 0; i < branches.size(); ++i) {
        const json& jb = branches[i];
        const std::string where = fmt::format("branches[{}]", i);
        if (!jb.is_object()) throw fail(where, "must be an object");
        CenterlineBranch b;
        if (jb.contains("name")) {
            if (!jb["name"].is_string()) throw fail(where + ".name", "must be a string");
            b.name = jb["name"].get<std::string>();
        }
        if (!jb.contains("parent")) throw fail(where + ".parent", "is missing");
        // The parent comes before the branch (-1: the root).
        b.parent = mucosa::detail::wholeNumber<int>(jb["parent"], where + ".parent", name, -1,
                                                    static_cast<int>(std::min<std::size_t>(i, 1u << 30)) - 1);
        if (jb.contains("generation"))
            b.generation = mucosa::detail::wholeNumber<int>(jb["generation"], where + ".generation", name, 0, 64);
        if (!jb.contains("points") || !jb["points"].is_array()) throw fail(where + ".points", "must be an array");
        for (std::size_t k = 0; k < jb["points"].size(); ++k) {
            const json& p = jb["points"][k];
            const std::string pw = fmt::format("{}.points[{}]", where, k);
            if (!p.is_array() || p.size() != 3) throw fail(pw, "must be [x, y, z]");
            b.points.push_back({finiteFloat(p[0], pw), finiteFloat(p[1], pw), finiteFloat(p[2], pw)});
        }
        if (!jb.contains("radii") || !jb["radii"].is_array()) throw fail(where + ".radii", "must be an array");
        for (std::size_t k = 0; k < jb["radii"].size(); ++k)
            b.radii.push_back(finiteFloat(jb["radii"][k], fmt::format("{}.radii[{}]", where, k)));
        if (b.radii.size() != b.points.size())
            throw InputError("centerline JSON", name,
                             fmt::format("branch {}: {} radii for {} points", i, b.radii.size(), b.points.size()));
        c.branches.push_back(std::move(b));
    }
    return c;
}

std::vector<Vec3> pathToBranch(const Centerline& c, int branch) {
    if (branch < 0 || branch >= static_cast<int>(c.branches.size()))
        throw InputError("branch", "", fmt::format("{} is not a branch of the centerline", branch));
    std::vector<int> chain;
    for (int b = branch; b >= 0; b = c.branches[static_cast<std::size_t>(b)].parent) chain.push_back(b);
    std::vector<Vec3> path;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it)
        for (const Vec3& p : c.branches[static_cast<std::size_t>(*it)].points)
            if (path.empty() || path.back() != p) path.push_back(p);
    return path;
}

}  // namespace mucosa::mesh
