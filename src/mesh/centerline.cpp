#include <mucosa/mesh/centerline.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

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
    const std::string name = path.string();
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(readTextFile(path));
    } catch (const nlohmann::json::exception& e) {
        throw InputError("centerline JSON", name, e.what());
    }
    Centerline c;
    try {
        c.axes = j.value("axes", "");
        const auto& branches = j.at("branches");
        for (std::size_t i = 0; i < branches.size(); ++i) {
            const auto& jb = branches[i];
            CenterlineBranch b;
            b.name = jb.value("name", "");
            b.parent = jb.at("parent").get<int>();
            b.generation = jb.value("generation", 0);
            for (const auto& p : jb.at("points"))
                b.points.push_back({p.at(0).get<float>(), p.at(1).get<float>(), p.at(2).get<float>()});
            b.radii = jb.at("radii").get<std::vector<float>>();
            if (b.radii.size() != b.points.size())
                throw InputError("centerline JSON", name,
                                 fmt::format("branch {}: {} radii for {} points", i, b.radii.size(), b.points.size()));
            if (b.parent >= static_cast<int>(i) || b.parent < -1)
                throw InputError("centerline JSON", name,
                                 fmt::format("branch {}: parent {} must come before it", i, b.parent));
            c.branches.push_back(std::move(b));
        }
    } catch (const nlohmann::json::exception& e) {
        throw InputError("centerline JSON", name, e.what());
    }
    return c;
}

std::vector<Vec3> pathToBranch(const Centerline& c, int branch) {
    if (branch < 0 || branch >= static_cast<int>(c.branches.size()))
        throw InputError("branch", "", fmt::format("{} is not a branch of the centreline", branch));
    std::vector<int> chain;
    for (int b = branch; b >= 0; b = c.branches[static_cast<std::size_t>(b)].parent) chain.push_back(b);
    std::vector<Vec3> path;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it)
        for (const Vec3& p : c.branches[static_cast<std::size_t>(*it)].points)
            if (path.empty() || path.back() != p) path.push_back(p);
    return path;
}

}  // namespace mucosa::mesh
