// mucosa mesh: inspect, repair, parameterise and convert meshes.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/dataset/orient.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/gltf.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>
#include <mucosa/scene/gltf_export.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct MeshArgs {
    std::vector<std::string> positional;
    std::string output, uv = "keep", unit = "auto", infoFile, infoUnit = "auto", orient = "keep";
    std::string material = "auto", look;  // --material, --look SCENE
    bool flip = false, weld = false, recomputeNormals = false, noTangents = false;
    float weldTolerance = 0;
};

std::string yesNo(bool b) {
    return b ? "yes" : "no";
}

void printInfo(const Global& g, const std::string& file, const std::string& unit) {
    mesh::LoadOptions lo;
    lo.unit = mesh::parseUnit(unit);
    lo.allowNonFinite = true;
    mesh::LoadInfo li;
    const mesh::Mesh m = mesh::load(file, lo, &li);
    const mesh::MeshReport r = mesh::analyze(m);
    for (const std::string& w : li.warnings) warn(w);
    std::string s;
    auto line = [&s](const std::string& l) { s += l + "\n"; };
    line(fmt::format("file:          {} ({} bytes, {})", file, li.fileBytes, li.format));
    line(fmt::format("units:         x{} to millimetres ({})", li.scaleToMillimetres, li.unitReason));
    line(fmt::format("axes:          {}", li.upAxis));
    line(fmt::format("parts:         {} triangle meshes merged{}", li.subMeshes,
                     li.droppedPrimitives ? fmt::format(", {} point/line meshes ignored", li.droppedPrimitives) : ""));
    line(fmt::format("vertices:      {} ({} distinct positions)", r.vertices, r.uniquePositions));
    line(fmt::format("triangles:     {}", r.triangles));
    line(fmt::format("bounds (mm):   [{:.2f}, {:.2f}, {:.2f}] .. [{:.2f}, {:.2f}, {:.2f}]", r.boundsMin[0],
                     r.boundsMin[1], r.boundsMin[2], r.boundsMax[0], r.boundsMax[1], r.boundsMax[2]));
    line(fmt::format("size (mm):     {:.2f} x {:.2f} x {:.2f}", r.boundsMax[0] - r.boundsMin[0],
                     r.boundsMax[1] - r.boundsMin[1], r.boundsMax[2] - r.boundsMin[2]));
    line(fmt::format("surface:       {:.1f} mm^2, enclosed volume {:.1f} mm^3{} ({})", r.surfaceArea, r.signedVolume,
                     r.boundaryLoops ? fmt::format(" with {} open ends capped", r.boundaryLoops) : "",
                     r.signedVolume >= 0 ? "winding faces outward" : "winding faces inward"));
    line(fmt::format("components:    {}", r.components));
    line(fmt::format("topology:      {} boundary edges, {} non-manifold edges, {} edges with flipped winding{}",
                     r.boundaryEdges, r.nonManifoldEdges, r.inconsistentEdges, r.watertight() ? " (watertight)" : ""));
    line(fmt::format("defects:       {} degenerate triangles, {} non-finite values, {} unused vertices",
                     r.degenerateTriangles, r.nonFiniteValues, r.unusedVertices));
    line(fmt::format("normals:       {}{}", li.fileHadNormals ? "in file" : "computed (angle-weighted)",
                     r.hasNormals
                         ? fmt::format(", {} not unit, {} against the winding", r.badNormals, r.normalsAgainstWinding)
                         : ""));
    line(fmt::format("uvs:           {}", yesNo(r.hasUvs)));
    line(fmt::format("tangents:      {}{}", yesNo(r.hasTangents),
                     r.hasTangents ? fmt::format(" ({} not unit / not _|_ N / w != +-1)", r.badTangents) : ""));
    if (r.stretch) {
        const mesh::UvStretch& st = *r.stretch;
        line(fmt::format(
            "uv stretch:    {:.4g} uv area per mm^2; per-triangle area ratio / mean: p5 {:.2f}, p50 {:.2f}, "
            "p95 {:.2f}",
            st.uvPerSurfaceArea, st.areaP05, st.areaP50, st.areaP95));
        line(fmt::format("               anisotropy sigma1/sigma2: p50 {:.2f}, p95 {:.2f}; {} zero-area, {} flipped",
                         st.anisotropyP50, st.anisotropyP95, st.zeroUvAreaTriangles,
                         count(st.flippedTriangles, "triangle")));
    }
    if (!g.quiet) std::fputs(s.c_str(), stdout);
}

// What material a glTF output gets (--material, --look).
struct MaterialPlan {
    bool gltfOut = false, gltfIn = false;
    std::string material;  // auto, keep, mucosa or plain
    scene::Scene look;     // Mucosa's material: --look's scene, or the default one
};

MaterialPlan planMaterial(const MeshArgs& a) {
    MaterialPlan p;
    const mesh::FileFormat out = mesh::outputFormat(a.output);
    p.gltfOut = out == mesh::FileFormat::Glb || out == mesh::FileFormat::Gltf;
    if (a.positional.size() == 1) {
        const mesh::FileFormat in = [&] {
            try {
                return mesh::outputFormat(a.positional[0]);
            } catch (const InputError&) {
                return mesh::FileFormat::Ply;  // any other: not glTF
            }
        }();
        p.gltfIn = in == mesh::FileFormat::Glb || in == mesh::FileFormat::Gltf;
    }
    p.material = a.material;
    if (!a.look.empty()) {
        if (a.material != "auto" && a.material != "mucosa")
            throw InputError("--look", "",
                             fmt::format("--look gives Mucosa's material; it contradicts --material {}", a.material));
        p.material = "mucosa";
    }
    if (p.material != "auto" && p.material != "keep" && p.material != "mucosa" && p.material != "plain")
        throw InputError("--material", "", fmt::format("'{}' is not one of auto, keep, mucosa, plain", p.material));
    if (p.material != "auto" && !p.gltfOut)
        throw InputError("--material", a.output, "materials are written to .glb and .gltf only");
    if (p.material == "keep" && !p.gltfIn)
        throw InputError("--material keep", a.positional.empty() ? "" : a.positional[0],
                         "only a glTF input's materials are kept (use auto, mucosa or plain)");
    // Read now, so a bad scene fails before the mesh work.
    p.look = a.look.empty() ? scene::defaultScene() : scene::loadSceneOrLook(a.look);
    for (const std::string& w : p.look.warnings) warn(w);
    return p;
}

// --material keep (and auto) with a glTF input and output: the file's own
// materials, textures, images and samplers (read from its JSON, not through
// Assimp), each triangle keeping its material. auto keeps only a file that
// has materials.
std::optional<mesh::GltfLook> keptLook(const MeshArgs& a, const MaterialPlan& p, const mesh::LoadInfo& li,
                                       mesh::Mesh& m) {
    if ((p.material != "keep" && p.material != "auto") || !p.gltfIn || !p.gltfOut) {
        m.materials.clear();
        return std::nullopt;
    }
    mesh::GltfLook look = mesh::readGltfLook(a.positional[0]);
    if (p.material == "auto" && look.materials.empty()) {
        m.materials.clear();
        return std::nullopt;
    }
    if (look.materials.size() != li.fileMaterials)
        throw InputError("materials", a.positional[0],
                         fmt::format("the importer found {} materials, the file has {}: cannot tell which part has "
                                     "which (re-export with --material mucosa or plain)",
                                     li.fileMaterials, look.materials.size()));
    if (a.uv == "centerline") {
        for (std::uint32_t t : m.materials)
            if (t != mesh::kNoMaterial && mesh::readsTexture(look.materials[t]))
                throw InputError("--uv centerline", a.positional[0],
                                 fmt::format("material {} is textured through the file's UVs, which centerline UVs "
                                             "would replace (keep the UVs, or use --material mucosa or plain)",
                                             t));
    }
    return look;
}

// The look written: the kept one pruned to the materials still in use,
// Mucosa's (--material mucosa, --look; auto when the mesh has UVs), or the
// plain one (auto without UVs).
std::optional<mesh::GltfLook> outputLook(const MeshArgs& a, const MaterialPlan& p, const Global& g, mesh::Mesh& m,
                                         std::optional<mesh::GltfLook>& kept) {
    if (!p.gltfOut) return std::nullopt;
    if (kept) {
        std::vector<bool> used(kept->materials.size(), false);
        for (std::uint32_t t : m.materials)
            if (t != mesh::kNoMaterial) used[t] = true;
        const std::vector<std::uint32_t> remap = mesh::pruneGltfLook(*kept, used);
        for (std::uint32_t& t : m.materials)
            if (t != mesh::kNoMaterial) t = remap[t];
        info(g, fmt::format("kept the file's look: {}, {}, {}", count(kept->materials.size(), "material"),
                            count(kept->textures.size(), "texture"), count(kept->images.size(), "image")));
        bool textured = false;
        for (const nlohmann::json& mat : kept->materials) textured = textured || mesh::readsTexture(mat);
        if (m.hasUvs() && !textured)
            warn(
                "the file's materials read no texture: TEXCOORD_0 is written for your own (validators note it as "
                "unused); --material mucosa textures it");
        return std::move(kept);
    }
    m.materials.clear();
    const bool doubleSided = scene::gltfDoubleSided(m);
    if (p.material == "mucosa" || (p.material == "auto" && m.hasUvs())) {
        if (!m.hasUvs())
            throw InputError("--material mucosa", a.positional[0],
                             "the mesh has no texture coordinates for Mucosa's textures (add --uv centerline)");
        scene::SceneAssets assets;
        scene::loadTextures(p.look, assets, g.threads);
        info(g, fmt::format("material: Mucosa's ({}){}", a.look.empty() ? "the default look" : a.look,
                            doubleSided ? ", double-sided" : ""));
        return scene::gltfLook(p.look, assets, doubleSided);
    }
    if (m.hasUvs())
        warn(
            "the plain material reads no texture: TEXCOORD_0 is written for your own (validators note it as "
            "unused); --material mucosa textures it");
    return scene::plainGltfLook(p.look.params, doubleSided);
}

void convert(const MeshArgs& a, const Global& g) {
    if (a.positional.size() != 1)
        throw InputError("arguments", "", "give one input mesh: mucosa mesh IN -o OUT (or mucosa mesh info FILE)");
    if (a.output.empty()) throw InputError("output", "", "give -o OUT (.glb, .gltf, .ply or .obj)");
    if (a.uv != "keep" && a.uv != "centerline")
        throw InputError("--uv", "", fmt::format("'{}' is not one of keep, centerline", a.uv));
    if (a.orient != "keep" && a.orient != "lumen")
        throw InputError("--orient", "", fmt::format("'{}' is not one of keep, lumen", a.orient));
    if (a.flip && a.orient == "lumen")
        throw InputError(
            "--flip", "",
            "give --flip or --orient lumen, not both (--orient lumen decides which way the surface faces)");
    const MaterialPlan plan = planMaterial(a);  // refuses a bad extension or material choice before any work
    requireWritable(a.output);
    const auto t0 = std::chrono::steady_clock::now();
    // Progress on stderr only for inputs big enough to take a while.
    std::error_code ec;
    bool verbose = std::filesystem::file_size(a.positional[0], ec) > (64u << 20) && !ec;
    auto progress = [&](const std::string& stage) {
        if (g.quiet || !verbose) return;
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::fprintf(stderr, "[%6.2f s] %s\n", s, stage.c_str());
    };
    mesh::LoadOptions lo;
    lo.unit = mesh::parseUnit(a.unit);
    mesh::LoadInfo li;
    progress("reading " + a.positional[0]);
    mesh::Mesh m = mesh::load(a.positional[0], lo, &li);
    verbose = verbose || m.triangleCount() > 1000000;
    for (const std::string& w : li.warnings) warn(w);
    std::optional<mesh::GltfLook> kept = keptLook(a, plan, li, m);
    info(g,
         fmt::format("read {}: {}, {}, x{} to mm ({})", a.positional[0], count(m.vertexCount(), "vertex", "vertices"),
                     count(m.triangleCount(), "triangle"), li.scaleToMillimetres, li.unitReason));
    bool tangentsStale = !m.hasTangents();
    if (a.weld) {
        progress("welding");
        const std::size_t removed = mesh::weld(m, a.weldTolerance);
        const std::size_t degenerate = mesh::removeDegenerateTriangles(m);
        const std::size_t unused = mesh::removeUnusedVertices(m);
        info(g,
             fmt::format("welded {}, dropped {} and {}", count(removed, "vertex", "vertices"),
                         count(degenerate, "degenerate triangle"), count(unused, "unused vertex", "unused vertices")));
        tangentsStale = true;
    }
    if (a.recomputeNormals || !m.hasNormals()) {
        progress("normals");
        mesh::recomputeNormals(m, g.threads);
        tangentsStale = true;
    }
    if (a.flip) {
        mesh::flipOrientation(m);
        info(g, "flipped: normals and winding now face the other side");
    }
    if (a.orient == "lumen") {
        // The centerline the shape gives (the level-set one the centerline
        // UVs follow: it does not depend on the winding), then the rays.
        progress("orienting to the lumen");
        mesh::Mesh shape;
        shape.positions = m.positions;
        shape.indices = m.indices;
        const mesh::CenterlineUvReport c = mesh::computeCenterlineUvs(shape);
        std::size_t points = 0;
        for (const mesh::CenterlineBranch& b : c.centerline.branches) points += b.points.size();
        if (points == 0)
            throw InputError("--orient lumen", a.positional[0],
                             "the mesh gives no centerline to look from (no tube in it); turn it with --flip instead");
        const dataset::LumenOrientReport r = dataset::orientToLumen(m, c.centerline, g.threads);
        info(g, fmt::format("oriented to the lumen: {} of {} turned ({}), {}; first hits of rays from the "
                            "centerline on the front: {:.1f} % (before: {:.1f} %)",
                            r.turnedPatches, count(r.patches, "patch", "patches"), count(r.turnedTriangles, "triangle"),
                            count(r.normalsTurned, "normal turned", "normals turned"), 100 * r.after.frontFraction(),
                            100 * r.before.frontFraction()));
        if (r.unseenPatches)
            warn(fmt::format("--orient lumen: {} no ray from the centerline meets left as they were",
                             count(r.unseenPatches, "patch", "patches")));
        tangentsStale = true;
    }
    if (a.uv == "centerline") {
        progress("centerline UVs");
        const mesh::CenterlineUvReport r = mesh::computeCenterlineUvs(m);
        info(g, fmt::format("centerline UVs: {}, {}, tile {:.2f} mm, {}", count(r.pieces, "piece"),
                            count(r.centerline.branches.size(), "branch", "branches"), r.tileLength,
                            count(r.seamVertices, "seam vertex", "seam vertices")));
        tangentsStale = true;
    }
    if (m.hasUvs() && !a.noTangents && tangentsStale) {
        progress("tangents");
        const mesh::TangentReport t = mesh::computeTangents(m, g.threads);
        info(g,
             fmt::format("tangents: {}, {}, {}, {}", count(t.mirroredVertices, "mirrored vertex", "mirrored vertices"),
                         count(t.degenerateUvTriangles, "zero-UV-area triangle"),
                         count(t.fallbackVertices, "fallback frame"),
                         count(t.splitVertices, "vertex split", "vertices split")));
    } else if (!m.hasUvs()) {
        m.tangents.clear();
        warn("no texture coordinates: written without tangents (try --uv centerline)");
    }
    if (a.noTangents) m.tangents.clear();
    progress("writing " + a.output);
    mesh::SaveOptions so;
    const std::optional<mesh::GltfLook> look = outputLook(a, plan, g, m, kept);
    so.look = look ? &*look : nullptr;
    mesh::save(m, a.output, so);
    info(g, fmt::format("wrote {} ({}, {})", a.output, count(m.vertexCount(), "vertex", "vertices"),
                        count(m.triangleCount(), "triangle")));
}

void addMeshCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<MeshArgs>();
    CLI::App* c =
        app.add_subcommand("mesh", "Inspect, repair, parameterise and convert meshes (mucosa mesh info FILE)");
    c->footer(
        "Examples:\n"
        "  mucosa mesh info airway.obj\n"
        "  mucosa mesh airway.obj -o airway.glb --orient lumen --uv centerline\n"
        "Reads what Assimp reads (OBJ, PLY, STL, glTF, FBX, ...); writes .glb/.gltf (metres; a glTF input keeps its\n"
        "materials and textures, others get Mucosa's wet look when they have UVs: docs/engines.md), .ply or .obj\n"
        "(millimetres).");
    c->add_option("input", a->positional, "Input mesh")->expected(0, 1);
    c->add_option("-o,--output", a->output, "Output mesh (.glb, .gltf, .ply, .obj)");
    c->add_option("--uv", a->uv,
                  "keep: the file's UVs; centerline: tube parameterisation around/along the lumen [keep]");
    c->add_flag("--flip", a->flip, "Turn the surface inside out (winding, normals and tangent handedness)");
    c->add_option("--orient", a->orient,
                  "keep: the file's winding; lumen: winding and normals into the lumen, decided by what rays from "
                  "the mesh's centerline see first [keep]");
    c->add_flag("--weld", a->weld, "Merge duplicate vertices, drop degenerate triangles");
    c->add_option("--weld-tolerance", a->weldTolerance, "Distance (mm) under which --weld merges vertices [0: exact]");
    c->add_flag("--recompute-normals", a->recomputeNormals, "Replace the normals with angle-weighted smooth normals");
    c->add_flag("--no-tangents", a->noTangents, "Do not write tangents");
    c->add_option("--material", a->material,
                  "glTF output's material: keep (a glTF input's own materials, textures and extensions), mucosa "
                  "(Mucosa's wet look: subject texture, reflectance map on a clearcoat; needs UVs), plain (one "
                  "untextured tissue colour), auto (keep for a glTF input with materials, else mucosa with UVs, "
                  "plain without) [auto]");
    c->add_option("--look", a->look,
                  "Mucosa's material from this scene file (its material, diffuse and reflectance_map) or look file "
                  "(mucosa look fit); implies --material mucosa");
    c->add_option("--unit", a->unit, "Unit of the input: auto, mm, cm, m, in [auto]");
    c->require_subcommand(0, 1);

    CLI::App* i =
        c->add_subcommand("info", "Report counts, bounds, topology, defects, normals/UVs/tangents, UV stretch");
    i->add_option("file", a->infoFile, "Mesh to inspect")->required();
    i->add_option("--unit", a->infoUnit, "Unit of the input: auto, mm, cm, m, in [auto]");
    i->callback([a, &g] { printInfo(g, a->infoFile, a->infoUnit); });
    c->callback([a, c, i, &g] {
        if (i->parsed()) return;
        (void)c;
        convert(*a, g);
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(20, addMeshCommand);

}  // namespace mucosa::cli
