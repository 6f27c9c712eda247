// mucosa mesh: inspect, repair, parameterise and convert meshes.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/dataset/orient.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct MeshArgs {
    std::vector<std::string> positional;
    std::string output, uv = "keep", unit = "auto", infoFile, infoUnit = "auto", orient = "keep";
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
    mesh::outputFormat(a.output);  // refuse a bad extension before any work
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
    mesh::save(m, a.output);
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
        "Reads what Assimp reads (OBJ, PLY, STL, glTF, FBX, ...); writes .glb/.gltf (POSITION, NORMAL, TEXCOORD_0,\n"
        "TANGENT), .ply or .obj, in millimetres.");
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
