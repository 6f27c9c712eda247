#pragma once
// Scene files (docs/scene-format.md): mesh, diffuse texture or colour,
// reflectance map (a file, or map parameters generated on load), material
// (every registry parameter), camera (a pose or a path), light, resolution.
// Without a file: the airway phantom with the 'bronchial' preset.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <mucosa/camera/camera.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/reflectance/appearance.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/shading/reference.hpp>

namespace mucosa::scene {

// What the mesh is: the built-in phantom, a curved analytic tube, or a file.
enum class MeshKind { Phantom, Tube, File };
// How the camera moves: one pose, key poses interpolated, or a fly-through
// along a centerline.
enum class PathKind { None, Poses, Centerline };

// The names scene files and messages use: "phantom", "tube", "file"; "none",
// "poses", "centerline".
std::string_view meshKindName(MeshKind kind) noexcept;
std::string_view pathKindName(PathKind kind) noexcept;
// The inverse; InputError(field, file, "unknown ... (known: ...)") for any other name.
MeshKind parseMeshKind(std::string_view name, const std::string& field = "mesh", const std::string& file = "");
PathKind parsePathKind(std::string_view name, const std::string& field = "camera.path", const std::string& file = "");

struct MeshSpec {
    MeshKind kind = MeshKind::Phantom;
    std::filesystem::path file;  // kind == MeshKind::File
    int phantomGenerations = 3;
    std::uint64_t phantomSeed = 1;
    double phantomResolution = 1.0;  // grid cells per mm
};

struct PathSpec {
    PathKind kind = PathKind::Centerline;
    std::vector<camera::Pose> poses;
    // Empty ("auto"): the mesh's own (phantom, tube); for a mesh file, a
    // <stem>.centerline.json or airway.centerline.json beside it, else one
    // computed from its shape (mesh::computeCenterlineUvs).
    std::filesystem::path centerlineFile;
    int branch = -1;  // centerline branch to fly to; -1 = the longest path
    // "route": true ("survey", the default) surveys the whole tree
    // (camera::surveyTree); false ("path", or a "branch") flies one path.
    bool survey = true;
    camera::FlyThrough fly;
    camera::Survey surveyOptions;
    // mm before the path's distal end where the flight stops ("stop_mm");
    // default: the near plane + the lumen's radius there + 3 mm, so the last
    // frame does not press into the wall closing a blind bronchus.
    std::optional<float> stopMm;
};

struct Scene {
    std::filesystem::path file;  // the scene file, or empty for the default scene
    MeshSpec mesh;
    std::optional<std::filesystem::path> diffuse;         // subject texture file
    bool generatedDiffuse = false;                        // "diffuse": "generated" (reflectance::tissueTexture)
    std::optional<std::filesystem::path> reflectanceMap;  // a map PNG; else generated from mapParams
    reflectance::MapParams mapParams;
    shading::Filter filter = shading::Filter::Mipmap;
    shading::Mode mode = shading::Mode::Noise;
    shading::ParamSet params;
    // "noise_space": where the procedural mode evaluates the map's noise
    // ("uv" or "object"); its parameters are mapParams.
    shading::NoiseSpace noiseSpace = shading::NoiseSpace::Uv;
    bool specularAA = true;  // "specular_aa" (shading::FrameSetup::specularAA)
    // "fit": the fitted atlas spans uv_min..uv_max (shading::FrameSetup::diffuseUvTransform).
    std::array<float, 4> diffuseUvTransform{1, 1, 0, 0};
    float normalSign = 1.0f;  // "lit_side": "front" (+1) or "back" (-1)
    // "closed": the mesh is watertight and wound counter-clockwise seen from
    // the lit side, so back faces can be culled. Default: true for the
    // built-in phantom (watertight by construction), false otherwise.
    std::optional<bool> closed;
    camera::Lens lens;
    // "camera.lens": the endoscope's lens model (docs/datasets.md, "Lens
    // models"): a lens object, kept as its JSON text, or the file of one (a
    // lens JSON, or OCamCalib's calib_results.txt). Neither: the pinhole of
    // lens.fovDeg. `mucosa render` reads it (dataset::lensFromJson).
    std::string lensModelJson;
    std::filesystem::path lensModelFile;
    camera::TipLight light;
    std::optional<camera::Pose> pose;  // a fixed pose (overrides the path's first pose)
    PathSpec path;
    int width = 640, height = 480;
    int frames = 1;
    // "outputs": what each frame writes besides its colour ("rgb,depth,normals",
    // or an array of names; `mucosa render --outputs` and dataset::parseOutputs
    // read it). Empty: the colour frame alone.
    std::string outputs;
    // "variation" / --variation: a patient's appearance drawn by
    // reflectance::drawAppearance (0: the default look). It shapes the
    // generated tissue texture (appearance.tissue), scales
    // material.mucus_opacity and specular_strength by the mucus amount and
    // the camera's softness, noise and flare by the scope's draw (those a
    // scene file sets itself stay), and adds appearance.exposureEv to
    // camera.exposure_ev (applyVariation).
    std::uint64_t variation = 0;
    reflectance::Appearance appearance = reflectance::defaultAppearance();
    // "tissue" / --set tissue.<key>: the generated texture's parameters the
    // scene sets by name (reflectance::tissueRegistry), over the patient's
    // appearance.tissue; a variation drawn later keeps them (tissueParams).
    std::map<std::string, double, std::less<>> tissue;
    // A look (applyLook, --look): the centre the patients vary about. The
    // registry values the variation scales are scaled from these instead of
    // the defaults; a patient's tissue is the look's moved by the draw's
    // difference from the default look (tissueParams).
    struct Look {
        std::vector<std::pair<shading::Param, float>> params;
        std::map<std::string, double, std::less<>> tissue;
    } look;
    // The material and camera parameters the scene file set explicitly.
    std::vector<shading::Param> fileMaterial;
    // What parsing accepted but warns about (a deprecated key), one line each
    // ("<field> in <file>: <why>"), for the CLI to print.
    std::vector<std::string> warnings;
};

// `--set reflectance_map.<key>=<value>`: one of the map parameters (the keys
// of a scene's "reflectance_map" object: preset, size, frequency, octaves,
// lacunarity, gain, seed, z, strength, turbulence, tileable), applied to the
// scene's map parameters, which both the generated map and the procedural
// mode use (a map file named by the scene is then replaced by the generated
// map). Throws InputError("--set reflectance_map.<key>", ...).
void setMapParameter(Scene& scene, const std::string& key, const std::string& value);

// `--set tissue.<key>=<value>` or a scene's "tissue" key: one of the
// generated texture's parameters (reflectance::tissueRegistry), checked
// against its range. Throws InputError(field, file, ...) naming the key
// (with the nearest known one for a typo).
void setTissueParameter(Scene& scene, const std::string& key, double value, const std::string& field,
                        const std::string& file = "");
// The generated texture's parameters: the patient's appearance.tissue moved
// to the look's centre (each look value plus the draw's difference from the
// default look, or times its ratio for the lengths and the vessel density,
// in range), then the scene's "tissue" values over it.
reflectance::TissueParams tissueParams(const Scene& scene);

// Draws patient `seed` (reflectance::drawAppearance; 0 = the default look)
// into scene.variation and scene.appearance, and sets material.mucus_opacity
// and specular_strength to their registry defaults times
// reflectance::mucusOpacityScale / specularScale of its mucus amount, and
// camera.softness_px, read_noise, full_well and flare to theirs times the
// scope's factors, except those in scene.fileMaterial. Applying another seed
// later replaces it.
void applyVariation(Scene& scene, std::uint64_t seed);

// A look file (`mucosa look fit` writes one; docs/look.md): a scene's
// "material", "light" and "camera" registry values, its "tissue" and
// "reflectance_map" objects, applied over `scene` — the mesh, path, lens and
// outputs stay the scene's. The look is the centre a variation varies
// about (Scene::look; the scene's variation is drawn again about it).
// Throws InputError(field, file, ...) as parseScene does; anything else in
// the file is refused.
void applyLook(Scene& scene, const std::filesystem::path& lookFile);
// The same with the look's values (checked by the caller), replacing the
// scene's look.
void applyLook(Scene& scene, const Scene::Look& look);

// A scene file, or a look file (a JSON object without "mesh") over the
// default scene: what `mucosa mesh --look` and `mucosa phantom --look` take.
Scene loadSceneOrLook(const std::filesystem::path& file);

// The built-in default: the phantom, 'bronchial' map (1024 texels), flying
// down the centerline.
Scene defaultScene();

// The default scene with a mesh file instead of the phantom ("mesh": file),
// flying along its centerline ("centerline": "auto").
Scene meshScene(const std::filesystem::path& meshFile);

// Parses a scene file. Relative paths are resolved against the file's folder.
// Throws InputError(field, file, why) naming the field ("material.shininess",
// "camera.pose.position", "mode", ...) for anything wrong, including unknown keys.
// A mesh file (an extension mesh::load reads: .obj, .ply, .stl, .gltf, .glb,
// ...; not .json) is taken as meshScene(path).
Scene loadScene(const std::filesystem::path& path);
Scene parseScene(const std::string& jsonText, const std::filesystem::path& fileForErrors);

// What a scene needs at render time, loaded/generated once.
struct SceneAssets {
    mesh::Mesh mesh;                     // with normals, uvs and tangents
    std::vector<mesh::Vec3> centerline;  // the fly-through polyline (mm); may be empty
    float centerlineEndRadius = 0;       // lumen radius at its distal end (mm); 0 = unknown
    std::vector<float> centerlineRadii;  // lumen radius at each centerline point (mm); empty = unknown
    // The centerline tree the path runs along (branch names, generations,
    // parents: the dataset's branch labels); no branches when unknown (the
    // tube, a path of poses).
    mesh::Centerline centerlineTree;
    image::Image8 diffuse;         // empty: none
    image::Image8 reflectanceMap;  // empty: not generated (loadAssets(..., false))
    // The multitexture baseline's highlight texture for the scene's shininess
    // (what Renderer generates; kept here for the C++ reference).
    image::Image8 highlight;
    std::vector<std::string> notes;  // what was loaded/generated, for the CLI to report
};

// `reflectanceMap`: false leaves SceneAssets::reflectanceMap empty when the
// scene names no map file (a procedural render needs none: no time or memory
// spent generating it; shading::info(mode).readsMap tells which modes read
// one); the renderer then keeps its flat default map.
SceneAssets loadAssets(const Scene& scene, int threads = 0, bool reflectanceMap = true);

// Only the textures of loadAssets: the diffuse texture (the file, or the
// generated one) and the reflectance map (the file, or generated unless
// `reflectanceMap` is false), into assets.diffuse / reflectanceMap, with notes.
void loadTextures(const Scene& scene, SceneAssets& assets, int threads = 0, bool reflectanceMap = true);

// A fly-through along a centerline tree, as a scene of a mesh file flies
// along its computed one: into `branch` (-1: the longest path from the
// root), leaf stubs (shorter than their radius: level-set rings at a cap or
// an open end) removed first. Sets assets' centerline, end radius and radii;
// returns the name of the branch the path ends in. `file` names the tree in
// errors.
std::string setFlightPath(SceneAssets& assets, const mesh::Centerline& centerline, int branch, const std::string& file);

// Camera poses for `frames` frames (scene.pose alone when frames == 1 and a
// pose is given; else along the path).
std::vector<camera::Pose> cameraPoses(const Scene& scene, const SceneAssets& assets, int frames);

// The per-frame values both renderers take.
shading::FrameSetup frameSetup(const Scene& scene, const camera::Pose& pose, int width, int height);

// Texture bindings for the C++ reference (views into `assets`).
shading::Textures referenceTextures(const Scene& scene, const SceneAssets& assets);

}  // namespace mucosa::scene
