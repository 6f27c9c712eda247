// mucosa export: a scene's mesh, maps and material as one glTF 2.0 asset.
#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/scene/gltf_export.hpp>
#include <mucosa/shading/gltf_material.hpp>

#include "commands.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

struct ExportArgs {
    SceneOptions scene;
    std::string output;
};

void addExportCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<ExportArgs>();
    CLI::App* c = app.add_subcommand(
        "export", "Write a scene's mesh, subject texture, reflectance map and material as one glTF 2.0 asset");
    c->footer(
        "Examples:\n"
        "  mucosa export scene.json -o airway.glb\n"
        "  mucosa export -o phantom.gltf --set material.shininess=200\n"
        "Base colour = the subject texture with the mucus layer baked in; KHR_materials_clearcoat with the\n"
        "reflectance map as its normal texture (tiled by KHR_texture_transform); KHR_materials_ior and\n"
        "KHR_materials_specular for the film's sheen. Metres, +Y up. See docs/engines.md.");
    addSceneOptions(c, a->scene, false);
    c->add_option("-o,--output", a->output, "Output asset (.glb: one binary file; .gltf: JSON with data URIs)")
        ->required();
    c->callback([a, &g] {
        const mesh::FileFormat format = mesh::outputFormat(a->output);
        if (format != mesh::FileFormat::Glb && format != mesh::FileFormat::Gltf)
            throw InputError("output", a->output, "mucosa export writes .glb or .gltf (a material needs glTF)");
        requireWritable(a->output);
        const scene::Scene s = resolveScene(a->scene);
        scene::SceneAssets assets = scene::loadAssets(s, g.threads);
        for (const std::string& n : assets.notes) info(g, n);
        mesh::Mesh& m = assets.mesh;
        if (!m.hasUvs())
            throw InputError("mesh", s.mesh.file.string(),
                             "has no texture coordinates for the textures (add them with mucosa mesh --uv centerline)");
        // The exported normals face the side the scene lights ("lit_side").
        if (s.normalSign < 0) mesh::flipOrientation(m);
        m.materials.clear();
        const bool doubleSided = scene::gltfDoubleSided(m);
        const mesh::GltfLook look = scene::gltfLook(s, assets, doubleSided);
        mesh::SaveOptions so;
        so.name = s.mesh.kind == scene::MeshKind::File ? s.mesh.file.stem().string()
                                                       : std::string(scene::meshKindName(s.mesh.kind));
        so.look = &look;
        mesh::save(m, a->output, so);
        const shading::GltfMaterialValues v = shading::gltfMaterialValues(s.params);
        if (v.clearcoatClamped)
            warn(
                fmt::format("material.specular_strength {} asks for more than a full clearcoat at shininess {}: "
                            "clearcoatFactor capped at 1",
                            s.params[shading::Param::SpecularStrength], s.params[shading::Param::Shininess]));
        info(g, fmt::format("wrote {} ({}, {}, {}; clearcoat {:.3f}, roughness {:.3f}, map x{}{})", a->output,
                            count(m.vertexCount(), "vertex", "vertices"), count(m.triangleCount(), "triangle"),
                            count(look.images.size(), "image"), v.clearcoatFactor, v.clearcoatRoughness, v.mapTiling,
                            doubleSided ? ", double-sided" : ""));
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(35, addExportCommand);

}  // namespace mucosa::cli
