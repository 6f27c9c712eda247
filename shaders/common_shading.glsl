// common_shading.glsl: Mucosa's shading model, written once.
//
// This file is compiled twice: as GLSL 3.30 (prepended to every surface_*
// shader by the renderer) and as C++20 with glm (src/shading/glsl.hpp includes
// it inside namespace mucosa::shading::glsl). So the GPU and the C++ reference
// share names, constants and the order of operations by construction
// (STYLE.md, "CPU and GPU agree by construction"). Keep to the subset both
// languages accept: float literals with an f suffix, no swizzles (use vec3(v)
// and .x/.y/.z), no in/out/inout parameters, no overloading on qualifiers.
// Notation follows docs/theory.md, "Shading model".

// Shading modes (shading::Mode, the --mode names, in this order).
const int kModeNoise = 0;          // the paper's method: per-pixel specular from the reflectance map
const int kModeVertexPhong = 1;    // baseline 1: per-vertex Phong, Gouraud-interpolated
const int kModeMultitexture = 2;   // baseline 2: per-vertex light x texture + sphere-mapped highlight texture
const int kModeDiffuse = 3;        // no specular (the paper's Category 3)
const int kModeNormals = 4;        // debug: the map's perturbed normal in world space, 0.5 N + 0.5
const int kModeTangents = 5;       // debug: tangent T in world space, 0.5 T + 0.5
const int kModeUv = 6;             // debug: fract(u), fract(v)
const int kModeDepth = 7;          // debug: 1 - r, r = depth ratio of eq. 10
const int kModeBrdf = 8;           // patient-specific: texture x rho(gamma) delta(r), nothing else (Category 3)
const int kModeBrdfNoise = 9;      // kModeBrdf plus the method's noise-based specular (Category 4)
const int kModeProcedural = 10;    // the method with run-time noise (procedural_noise.glsl), no map
const int kModeProceduralNormals = 11;  // debug: kModeProcedural's perturbed normal in world space, 0.5 N + 0.5
const int kModeClearcoat = 12;     // glTF's clear coat (KHR_materials_clearcoat) over the glTF base, per pixel
const int kModeClearcoatProcedural = 13;  // kModeClearcoat with the coat's normal from the run-time noise
const int kModeCount = 14;

// What each mode reads, asked by the fragment shader and by the C++ reference
// alike. shading::ModeInfo (src/shading/params.cpp) is the same table for the
// rest of the C++; static_asserts there check that the two agree, mode by mode.
// MUCOSA_CONSTEXPR is constexpr in C++ (src/shading/glsl.hpp) and nothing in GLSL.
#ifndef MUCOSA_CONSTEXPR
#define MUCOSA_CONSTEXPR
#endif
// The subject (diffuse) texture: every mode but the debug views.
MUCOSA_CONSTEXPR bool modeReadsDiffuse(int mode) {
    return mode != kModeNormals && mode != kModeTangents && mode != kModeUv && mode != kModeDepth &&
           mode != kModeProceduralNormals;
}
// The reflectance map (the method's specular, and its normals view).
MUCOSA_CONSTEXPR bool modeReadsReflectanceMap(int mode) {
    return mode == kModeNoise || mode == kModeNormals || mode == kModeBrdfNoise || mode == kModeClearcoat;
}
// The sphere-mapped highlight texture (baseline 2).
MUCOSA_CONSTEXPR bool modeReadsHighlight(int mode) {
    return mode == kModeMultitexture;
}
// Linear radiance for the endoscope's camera (camera.glsl) rather than display
// values: the modes that show the tissue as a camera would, not the debug
// views, nor the fitted modes (their texture and rho, delta already are a
// camera's output).
MUCOSA_CONSTEXPR bool modeIsPhotographic(int mode) {
    return mode == kModeNoise || mode == kModeVertexPhong || mode == kModeMultitexture || mode == kModeDiffuse ||
           mode == kModeProcedural || mode == kModeClearcoat || mode == kModeClearcoatProcedural;
}
// The modes whose body light scatters under the surface (scatter.glsl): the
// photographic modes with a separate white specular. Not the clear coat, a
// glTF engine's material, which has no scattering: its diffuse base and coat
// stay in one colour.
MUCOSA_CONSTEXPR bool modeScatters(int mode) {
    return mode == kModeNoise || mode == kModeVertexPhong || mode == kModeMultitexture || mode == kModeDiffuse ||
           mode == kModeProcedural;
}
// The largest finite half float: the camera's HDR target (RGBA16F) holds no more.
const float kHalfMax = 65504.0f;
// Noise evaluated per pixel (procedural_noise.glsl) instead of the map.
MUCOSA_CONSTEXPR bool modeIsProcedural(int mode) {
    return mode == kModeProcedural || mode == kModeProceduralNormals || mode == kModeClearcoatProcedural;
}

// Below this, a decoded map normal's z is clamped: a map texel with blue <= 0.5
// (a back-facing normal, impossible in a valid map) must not give NaN.
const float kMinNormalZ = 0.001f;
// Guards against division by zero for degenerate inputs (zero-length vectors).
const float kTiny = 1e-6f;
// The reflectance map's mip levels carry the slope deviation sigma of the
// texels they average in alpha, as a = sigma / kMapSigmaMax
// (reflectance::specularMipChain).
const float kMapSigmaMax = 0.5f;

// Material and light: the parameter registry's values (src/shading/params.cpp),
// packed by shading::glsl::packMaterial.
struct Material {
    vec3 baseColor;          // albedo multiplier of the diffuse texture
    vec3 mucusColor;         // colour of the mucous layer
    float mucusOpacity;      // 0 = clear mucus, 1 = opaque
    float specularStrength;  // k_s
    float shininess;         // Phong exponent n
    float bumpScale;         // scales the map normal's tilt (0 = flat)
    float mapTiling;         // map repeats per unit of texture coordinate
    float ambient;           // k_a
    vec4 c;                  // c0..c3 of rho(gamma), paper eq. 9
    vec3 d;                  // d1..d3 of delta(r), paper eq. 10
    float depthMin;          // z_min (mm)
    float depthMax;          // z_max (mm)
    float lightIntensity;    // I_L: the lamp's radiant intensity on its axis (irradiance x mm^2)
    float lampSourceRadius;  // a: radius (mm) of the lamp's emitting disk
    float lampSpread;        // mu: the lamp's angular fall-off, exp(-mu (1 - cos theta))
    float wrap;              // w: wrap lighting (sub-surface approximation)
    float sheenStrength;     // k_sheen: the mucus film's broad lobe
    float sheenShininess;    // its Phong exponent
    float mucusF0;           // Fresnel reflectance of the film at normal incidence
    float clearcoat;           // clearcoat mode: the coat's weight (glTF clearcoatFactor)
    float clearcoatRoughness;  // its GGX roughness (alpha = roughness^2)
    float baseRoughness;       // the glTF base's specular roughness (from sheenShininess, shading::glsl::packMaterial)
};

// Per-frame values (camera and light positions in world space, mm).
struct Frame {
    mat4 viewProj;
    mat4 view;
    vec3 eye;
    vec3 light;
    vec3 lampAxis;    // the scope's viewing direction (world, unit): the lamp's axis
    float normalSign;  // +1, or -1 to view a mesh from the side its normals point away from
    int specularAA;    // 1: specular anti-aliasing (Toksvig on the map's mips; octave fade procedurally)
    vec4 diffuseUvTransform;  // subject texture at uv * xy + zw (a fitted atlas spanning uv_min..uv_max)
};

// The light at the eye (the endoscope's headlight: a tip light with no
// offset, the default) makes L = V, and Lt = Vt bit for bit. The renderer then
// compiles the fragment stage with MUCOSA_HEADLIGHT defined, so the modes that
// light per pixel read one interpolated tangent-space vector instead of two:
// the same values, and two fewer attribute slots for the rasteriser to set up
// and interpolate (uv, Lt, Vt and the two per-vertex terms are 10 floats, 3
// vec4 slots; without Lt, 2): on llvmpipe the noise mode's frame is ~5 %
// shorter at 640x480. The C++ reference reads the vectors as they are.
#ifdef MUCOSA_HEADLIGHT
#define MUCOSA_LIGHT_T(v) v.Vt
#define MUCOSA_LIGHT_POSITION(f) f.eye
#else
#define MUCOSA_LIGHT_T(v) v.Lt
#define MUCOSA_LIGHT_POSITION(f) f.light
#endif

// Everything the vertex stage hands the fragment stage (all interpolated
// perspective-correctly). Only floats: the C++ rasteriser interpolates it as an
// array. The renderer declares one interface variable per member (v<Name>,
// src/render/uniforms.cpp) and copies through them.
struct Varyings {
    vec3 Lt;             // surface -> light, tangent space (unnormalised)
    vec3 Vt;             // surface -> eye, tangent space (unnormalised)
    vec2 uv;             // texture coordinates
    vec3 T;              // world tangent frame (debug views)
    vec3 B;
    vec3 N;
    float diffuseLight;  // E rho delta (per vertex in every mode; the fitted modes: I_L-free rho delta)
    float specular;      // E k_s, times the Phong lobe in vertex-phong (E: the lamp's irradiance)
    float sheen;         // the mucus film's sheen, E sheenLobe (noise, procedural; 0 in the other modes)
    vec2 sphereUv;       // multitexture: highlight-texture coordinates (highlightCoord)
    vec3 P;              // world position (mm): procedural noise in object space, per-pixel L and V
    vec3 tint;           // the mesh's per-vertex tint (linear RGB; 1 without colours): multiplies the albedo
};

// Paper eq. 1-2 inverted: rgb = 0.5 N + 0.5 -> N; the bump scale tilts the
// normal (scales the slopes -Hu, -Hv) before renormalising.
vec3 decodeReflectanceNormal(vec3 rgb, float bumpScale) {
    vec3 n = rgb * 2.0f - vec3(1.0f);
    return normalize(vec3(n.x * bumpScale, n.y * bumpScale, max(n.z, kMinNormalZ)));
}

// Paper eq. 9: rho(gamma) = c0 + c1 gamma + c2 gamma^2 + c3 gamma^3 (Horner).
float brdfRho(float gamma, vec4 c) {
    return c.x + gamma * (c.y + gamma * (c.z + gamma * c.w));
}

// Paper eq. 10: delta(r) = 1 + d1 r + d2 r^2 + d3 r^3 (Horner).
float depthDelta(float r, vec3 d) {
    return 1.0f + r * (d.x + r * (d.y + r * d.z));
}

// Paper eq. 10: r = (z - zmin) / (zmax - zmin), clamped to [0, 1].
float depthRatio(float z, float zmin, float zmax) {
    return clamp((z - zmin) / max(zmax - zmin, kTiny), 0.0f, 1.0f);
}

// The endoscope's lamp (docs/theory.md, "The endoscope's lamp"): the
// irradiance at distance d, at angle theta from the lamp's axis, is
//   E = I_L exp(-mu (1 - cos theta)) / (d^2 + a^2),
// the spot-light-source model of endoscope light guides (Modrzejewski et al.
// 2020, EndoMapper) with inverse-square fall-off; a^2 keeps it finite at the
// tip: I / (d^2 + a^2) is the exact on-axis irradiance of a Lambertian disk of
// radius a, and 1 / d^2 beyond a few radii.
float lampIrradiance(float dist, float cosTheta, Material m) {
    float a = m.lampSourceRadius;
    return m.lightIntensity * exp(-m.lampSpread * (1.0f - cosTheta)) / (dist * dist + a * a);
}

// Wrap lighting (a sub-surface approximation, as in GPU Gems 1, ch. 16): the
// diffuse cosine becomes (cos + w) / (1 + w), so light reaches a little past
// the terminator and shading is softer, as in translucent tissue.
float wrapCosine(float cosine, float w) {
    return max((cosine + w) / (1.0f + w), 0.0f);
}

// The ambient term: light scattered back by the airway's walls, k_a times the
// lamp's irradiance at kAmbientDistanceMm (so it follows the lamp's power
// and the exposure treats it like the direct light).
const float kAmbientDistanceMm = 10.0f;
float ambientIrradiance(Material m) {
    return m.ambient * m.lightIntensity / (kAmbientDistanceMm * kAmbientDistanceMm);
}

// Schlick's approximation of the Fresnel reflectance of a dielectric film.
float fresnelSchlick(float cosine, float f0) {
    float q = 1.0f - clamp(cosine, 0.0f, 1.0f);
    float q2 = q * q;
    return f0 + (1.0f - f0) * (q2 * q2 * q);
}

// Only where the lamp reaches: the method's glints and the sheen fade out as
// the surface turns away from the lamp (cosine of the geometric normal).
float lampReach(float cosNL) {
    return smoothstep(0.0f, 0.1f, cosNL);
}

// The mucus film's broad sheen (docs/theory.md, "Wet tissue"): an
// energy-normalised Phong lobe on the smooth film's normal (the tangent
// frame's N), times Fresnel, times cos(theta_i), for irradiance 1:
//   k_sheen F(N.V) (n + 2) / 2 (R.V)^n cos(theta_i).
// (The BRDF k_sheen F (n + 2) / (2 pi) (R.V)^n; the pi is the one the diffuse
// term leaves out.) Its directional albedo is at most k_sheen <= 1.
// From the cosines N.L, N.V and R.V (R = reflect(-L, N)) of unit vectors.
float sheenLobe(float cosNL, float cosNV, float cosRV, Material m) {
    float n = m.sheenShininess;
    return m.sheenStrength * fresnelSchlick(cosNV, m.mucusF0) * (0.5f * (n + 2.0f)) * pow(max(cosRV, 0.0f), n) *
           max(cosNL, 0.0f);
}

// Paper eq. 11 without the albedo: rho(gamma) delta(r), gamma = cos(V, N),
// z = distance to the viewpoint.
float diffuseShading(float gamma, float z, Material m) {
    return brdfRho(max(gamma, 0.0f), m.c) * depthDelta(depthRatio(z, m.depthMin, m.depthMax), m.d);
}

// Phong 1975 lobe: (max(R . V, 0))^n, R = L reflected about N.
float phongLobe(vec3 N, vec3 L, vec3 V, float shininess) {
    vec3 R = reflect(-L, N);
    return pow(max(dot(R, V), 0.0f), shininess);
}

// Toksvig 2005, "Mipmapping normal maps", for the Phong lobe: a normal that
// varies inside the pixel with per-axis slope variance sigma2 widens the
// lobe. Phong's (R.V)^n is Blinn-Phong's (N.H)^(4n) near the peak, and
// Toksvig's s' = s / (1 + s sigma2) for the Blinn exponent s gives
// n' = n / (1 + 4 n sigma2) (docs/theory.md, "Specular anti-aliasing").
float toksvigShininess(float shininess, float sigma2) {
    return shininess / (1.0f + 4.0f * shininess * sigma2);
}

// The method's specular lobe for the perturbed normal Np with slope variance
// sigma2 (0: a sharp normal, the plain Phong lobe). The widened lobe is scaled
// by (n' + 1) / (n + 1), the ratio of the lobes' integrals, so a pixel keeps
// the energy its sub-pixel glints would have reflected.
// Branch-free: with sigma2 = 0 it is exactly the plain lobe (n' = n / 1 and
// (n + 1) / (n + 1) = 1 in IEEE arithmetic), and SIMD rasterisers such as
// llvmpipe run both sides of a branch, so one pow serves both cases.
float methodSpecular(vec3 Np, vec3 L, vec3 V, float sigma2, float shininess) {
    float n = toksvigShininess(shininess, sigma2);
    return phongLobe(Np, L, V, n) * ((n + 1.0f) / (shininess + 1.0f));
}

// Slope variance stored in a map sample's alpha (kMapSigmaMax).
float mapSlopeVariance(float a) {
    float sigma = a * kMapSigmaMax;
    return sigma * sigma;
}

// The mucous layer's colour and transparency (paper, Results): light scattered
// back by the layer mixes with the tissue beneath.
vec3 mucusAlbedo(vec3 albedo, Material m) {
    return mix(albedo, m.mucusColor, m.mucusOpacity);
}

// glTF's clear coat (KHR_materials_clearcoat over the core metallic-roughness
// BRDF of glTF 2.0, Appendix B; docs/theory.md, "Clear coat"). Radiance in
// Mucosa's units (pi x BRDF x E cos: a Lambertian albedo a gives a E).
const float kPi = 3.14159265f;
// The coat's Fresnel reflectance at normal incidence: the extension fixes its
// IOR at 1.5, so F0 = ((1.5 - 1) / (1.5 + 1))^2.
const float kClearcoatF0 = 0.04f;
// A point lamp needs a minimum roughness to show a highlight at all (GGX
// tends to a delta as alpha -> 0); Filament's and three.js's bound.
const float kMinGgxRoughness = 0.045f;

// GGX (Trowbridge-Reitz) normal distribution D(N.H), alpha = roughness^2.
float ggxDistribution(float cosNH, float alpha) {
    float a2 = alpha * alpha;
    float c = max(cosNH, 0.0f);
    float t = c * c * (a2 - 1.0f) + 1.0f;
    return a2 / (kPi * t * t);
}

// The height-correlated Smith visibility V = G / (4 |N.L| |N.V|) of glTF 2.0,
// Appendix B (Heitz 2014), for cosines clamped to [0, 1].
float smithVisibility(float cosNL, float cosNV, float alpha) {
    float a2 = alpha * alpha;
    float l = max(cosNL, 0.0f);
    float v = max(cosNV, 0.0f);
    float gv = l * sqrt(v * v * (1.0f - a2) + a2);
    float gl = v * sqrt(l * l * (1.0f - a2) + a2);
    return gv + gl > 0.0f ? 0.5f / (gv + gl) : 0.0f;
}

// Schlick's Fresnel with a reflectance f90 at grazing incidence
// (KHR_materials_specular scales both ends).
float fresnelSchlick90(float cosine, float f0, float f90) {
    float q = 1.0f - clamp(cosine, 0.0f, 1.0f);
    float q2 = q * q;
    return f0 + (f90 - f0) * (q2 * q2 * q);
}

// GGX alpha = roughness^2, the roughness bounded below for the point lamp.
float ggxAlpha(float roughness) {
    float r = max(roughness, kMinGgxRoughness);
    return r * r;
}

// glTF's clear-coated dielectric (metallic 0) lit by the lamp: unit vectors
// Ng (the geometry's normal: the base), Nc (the coat's normal: the map's),
// L (to the lamp) and V (to the eye), the lamp's irradiance E, the ambient
// irradiance Ea (diffuse only, like an engine's ambient light).
//   base = E (N.L) [albedo (1 - F_b(V.H)) + pi F_b(V.H) D_b V_b] + albedo Ea
//     (glTF 2.0 Appendix B fresnel_mix: F0_b = ((n - 1) / (n + 1))^2 x
//     specular, F90_b = specular; KHR_materials_ior, KHR_materials_specular)
//   coat = pi D_c V_c E (Nc.L)
//   result = base (1 - w F_c(Nc.V)) + w F_c(Nc.V) coat
// (KHR_materials_clearcoat's fresnel_coat: the coat's Fresnel at Nc.V, F0 0.04.)
vec3 clearcoatShading(vec3 albedo, vec3 Ng, vec3 Nc, vec3 L, vec3 V, float E, float Ea, Material m) {
    vec3 H = normalize(L + V);
    float cosNL = max(dot(Ng, L), 0.0f);
    float cosNV = max(dot(Ng, V), 0.0f);
    float cosVH = max(dot(V, H), 0.0f);
    float baseAlpha = ggxAlpha(m.baseRoughness);
    float coatAlpha = ggxAlpha(m.clearcoatRoughness);
    float f90 = m.sheenStrength;
    float Fb = fresnelSchlick90(cosVH, min(m.mucusF0, 1.0f) * f90, f90);
    float specB = kPi * Fb * ggxDistribution(dot(Ng, H), baseAlpha) * smithVisibility(cosNL, cosNV, baseAlpha);
    vec3 base = albedo * (E * cosNL * (1.0f - Fb) + Ea) + vec3(E * cosNL * specB);
    float cosCL = max(dot(Nc, L), 0.0f);
    float cosCV = max(dot(Nc, V), 0.0f);
    float Fc = m.clearcoat * fresnelSchlick(cosCV, kClearcoatF0);
    float coat = kPi * ggxDistribution(dot(Nc, H), coatAlpha) * smithVisibility(cosCL, cosCV, coatAlpha) * E * cosCL;
    return base * (1.0f - Fc) + vec3(Fc * coat);
}

// The clearcoat modes' fragment: per pixel in world space, like an engine:
// the lamp at the light's position, the geometric normal for the base, the
// coat's normal Nc (the map's or the noise's, in world space) for the coat.
vec3 clearcoatFragment(vec3 albedo, vec3 Nc, Varyings v, float ambientE, Material m, Frame f) {
    vec3 toLight = MUCOSA_LIGHT_POSITION(f) - v.P;
    float dl = max(length(toLight), kTiny);
    vec3 L = toLight / dl;
    vec3 V = normalize(f.eye - v.P);
    float E = lampIrradiance(dl, -dot(L, f.lampAxis), m);
    return clearcoatShading(albedo, normalize(v.N), Nc, L, V, E, ambientE, m);
}

// Paper eq. 7: to tangent space with R = [T; B; N] (rows).
vec3 toTangentSpace(vec3 v, vec3 T, vec3 B, vec3 N) {
    return vec3(dot(T, v), dot(B, v), dot(N, v));
}

// The multitexture baseline's texture coordinates: OpenGL's GL_SPHERE_MAP
// formula (OpenGL 1.x spec, 2.11.4) applied to the reflected light direction
// R = reflect(-L, N), expressed in a frame whose pole is V (the direction to
// the eye) instead of the eye-space z axis. The highlight texture is then the
// Phong lobe (R . V)^n and lands where a Phong highlight would; computed per
// vertex and interpolated linearly, it gives the faceted, polygonal highlights
// of fixed-function multi-texturing on coarse meshes (the paper's Fig. 2).
vec2 highlightCoord(vec3 N, vec3 L, vec3 V, Frame f) {
    vec3 R = reflect(-L, N);
    vec3 right = vec3(f.view[0][0], f.view[1][0], f.view[2][0]);  // camera +x in world space
    vec3 x = normalize(right - V * dot(right, V));
    vec3 y = cross(V, x);
    vec3 r = vec3(dot(R, x), dot(R, y), dot(R, V));
    float m = 2.0f * sqrt(r.x * r.x + r.y * r.y + (r.z + 1.0f) * (r.z + 1.0f));
    m = max(m, kTiny);
    return vec2(r.x / m + 0.5f, r.y / m + 0.5f);
}

vec4 tissueClipPosition(vec3 P, Frame f) {
    return f.viewProj * vec4(P, 1.0f);
}

// Vertex stage. N0 = vertex normal, T0 = tangent (xyz, w = handedness with
// B = w cross(N, T), glTF's convention), P in world space (mm).
// tint: the vertex's colour (mesh::Mesh::colors; white without).
Varyings tissueVertex(vec3 P, vec3 N0, vec4 T0, vec2 uv, vec3 tint, Frame f, Material m, int mode) {
    Varyings o;
    vec3 Ng = normalize(N0);
    vec3 T = normalize(vec3(T0));
    vec3 B = T0.w * cross(Ng, T);
    vec3 N = Ng * f.normalSign;
    vec3 L = f.light - P;
    vec3 V = f.eye - P;
    o.Lt = toTangentSpace(L, T, B, N);
    o.Vt = toTangentSpace(V, T, B, N);
    o.uv = uv;
    o.T = T;
    o.B = B;
    o.N = N;
    o.diffuseLight = 0.0f;
    o.specular = 0.0f;
    o.sheen = 0.0f;
    o.sphereUv = vec2(0.0f);
    o.P = P;
    o.tint = tint;
    // The diffuse term (paper eq. 11, with wrap lighting), the lamp's
    // irradiance and the film's broad sheen are per vertex in every mode: the
    // modes differ only in how the highlight is made, and the per-pixel work
    // of the method is its specular term.
    float dl = max(length(L), kTiny);
    float dv = max(length(V), kTiny);
    vec3 Ln = L / dl;
    vec3 Vn = V / dv;
    float cosNL = dot(N, Ln);
    float E = lampIrradiance(dl, -dot(Ln, f.lampAxis), m);
    float reachE = E * lampReach(cosNL);
    o.diffuseLight =
        E * brdfRho(wrapCosine(cosNL, m.wrap), m.c) * depthDelta(depthRatio(dv, m.depthMin, m.depthMax), m.d);
    o.specular = reachE * m.specularStrength;
    // The sheen is a broad lobe on the smooth film (the geometric normal):
    // per vertex, like the diffuse term; the method's modes only.
    if (mode == kModeNoise || mode == kModeProcedural)
        o.sheen = reachE * sheenLobe(cosNL, dot(N, Vn), dot(reflect(-Ln, N), Vn), m);
    if (mode == kModeVertexPhong) {
        o.specular = o.specular * phongLobe(N, Ln, Vn, m.shininess);
    }
    // The fitted model (paper eq. 11): delta(r) is the whole fall-off with
    // distance, so no point-light attenuation on the diffuse term.
    // The fit's c and d carry the light's strength (mucosa fit solves for
    // rho delta with I_L = 1), so the lamp's I_L is not applied either. Its
    // specular (brdf-noise) has no fall-off: k_s.
    if (mode == kModeBrdf || mode == kModeBrdfNoise) {
        o.diffuseLight = diffuseShading(dot(N, Vn), dv, m);
        o.specular = m.specularStrength;
    }
    if (mode == kModeMultitexture) {
        o.sphereUv = highlightCoord(N, Ln, Vn, f);
    }
    return o;
}

// Where the fragment stage samples the subject (diffuse) texture: the identity,
// or a fitted atlas's rectangle mapped to [0, 1] (mucosa fit, scene key "fit").
vec2 diffuseCoord(vec2 uv, Frame f) {
    return vec2(uv.x * f.diffuseUvTransform.x + f.diffuseUvTransform.z,
                uv.y * f.diffuseUvTransform.y + f.diffuseUvTransform.w);
}

// Where the fragment stage samples the reflectance map.
vec2 reflectanceMapCoord(vec2 uv, Material m) {
    return uv * m.mapTiling;
}

// Where the procedural path evaluates its noise: texture space in map widths
// (u, -v) (the map's v runs down its rows, texture v up), or the world
// position in map widths (solid noise). Unwrapped: the caller takes the
// footprint from its screen-space derivatives.
vec3 proceduralCoord(Varyings v, Material m, Procedural pr) {
    if (MUCOSA_PR_SPACE(pr) == kSpaceObject) return v.P * (1.0f / pr.scaleMm);
    return vec3(v.uv.x * m.mapTiling, -(v.uv.y * m.mapTiling), 0.0f);
}

// The pixel footprint in noise coordinates from the screen-space derivatives
// of proceduralCoord (dFdx, dFdy in GLSL).
float noiseFootprint(vec3 qdx, vec3 qdy) {
    return max(length(qdx), length(qdy));
}

// The map's slope variance in a (filtered) map sample when anti-aliasing.
float mapSampleVariance(vec4 mapSample, Material m, Frame f) {
    if (f.specularAA == 0) return 0.0f;
    return mapSlopeVariance(mapSample.w) * m.bumpScale * m.bumpScale;
}

// Specular light (the lobe, the sheen) reaches only a pixel whose smooth,
// geometric surface faces the lamp: N.L > 0, the normal component of the
// interpolated tangent-space light vector (lit_side's N). The vertex stage
// fades it out towards the terminator (lampReach), but interpolated across a
// triangle that straddles it the faded term reaches past it, the fitted
// modes' k_s has no fall-off at all, and a perturbed normal (the map's, the
// noise's) can face the lamp where the surface does not.
float specularGate(Varyings v) {
    return MUCOSA_LIGHT_T(v).z > 0.0f ? 1.0f : 0.0f;
}

// Fragment stage, after the caller sampled the textures: albedoTex at v.uv,
// mapSample at reflectanceMapCoord(v.uv) (rgb = 0.5 N + 0.5, a = slope
// deviation, see kMapSigmaMax), highlight at v.sphereUv, and footprint =
// noiseFootprint of proceduralCoord. albedoTex is sRGB-encoded (decoded here;
// the fitted modes read it as it is). Returns linear radiance for the
// photographic modes (shading::ModeInfo::photographic: the camera,
// camera.glsl, comes next), display values in [0, 1] for the others.
// Split in two (tissueFragment adds them): rgb, the body's light, which the
// modes that scatter (modeScatters) diffuse under the surface (scatter.glsl);
// a, the white light the mucus film reflects. The other modes return
// everything in rgb.
vec4 tissueFragmentParts(Varyings v, vec3 albedoTex, vec4 mapSample, float highlight, float footprint, Material m,
                         Procedural pr, Frame f, int mode) {
    vec3 albedo = mucusAlbedo(srgbToLinear3(albedoTex) * m.baseColor * v.tint, m);
    float ambientE = ambientIrradiance(m);
    vec3 mapRgb = vec3(mapSample);
    if (mode == kModeNoise) {
        // Per pixel: the map's normal and the Phong lobe (paper, "Lighting in
        // tangent space"), with L and V interpolated in tangent space.
        vec3 Nm = decodeReflectanceNormal(mapRgb, m.bumpScale);
        float spec = methodSpecular(Nm, normalize(MUCOSA_LIGHT_T(v)), normalize(v.Vt),
                                    mapSampleVariance(mapSample, m, f), m.shininess);
        return vec4(albedo * (ambientE + v.diffuseLight), (v.specular * spec + v.sheen) * specularGate(v));
    }
    if (mode == kModeProcedural || mode == kModeProceduralNormals || mode == kModeClearcoatProcedural) {
        // The noise gradient as a surface gradient (Mikkelsen 2010): the
        // normal tilts against it, scaled by strength x bump scale.
        vec3 q = proceduralCoord(v, m, pr);
        if (MUCOSA_PR_SPACE(pr) == kSpaceUv && MUCOSA_PR_TILEABLE(pr) != 0) q = fract(q);
        FractalSample s = fractalNoise(q, footprint, pr);
        float slope = pr.strength * m.bumpScale;
        float sigma2 = slope * slope * s.fadedVariance;
        float specP = 0.0f;
        if (MUCOSA_PR_SPACE(pr) == kSpaceUv) {
            // In tangent coordinates the surface gradient is (Hu, Hv, 0), with
            // Hu = dH/du and Hv = -dH/dq.y (texture v runs against q.y), as
            // the map's normals are made (reflectance::encodeNormals8).
            vec3 Nt = normalize(vec3(-(slope * s.h.y), slope * s.h.z, 1.0f));
            if (mode == kModeProceduralNormals)
                return vec4(normalize(Nt.x * v.T + Nt.y * v.B + Nt.z * v.N) * 0.5f + vec3(0.5f), 0.0f);
            if (mode == kModeClearcoatProcedural) {
                vec3 Nc = normalize(Nt.x * v.T + Nt.y * v.B + Nt.z * v.N);
                return vec4(clearcoatFragment(albedo, Nc, v, ambientE, m, f), 0.0f);
            }
            specP = methodSpecular(Nt, normalize(MUCOSA_LIGHT_T(v)), normalize(v.Vt), sigma2, m.shininess);
        } else {
            // Solid noise h(P) = strength scale H(P / scale): grad h =
            // strength grad_q H; its part in the surface's plane tilts N.
            vec3 N = normalize(v.N);
            vec3 g = vec3(s.h.y, s.h.z, s.h.w) * slope;
            vec3 Np = normalize(N - (g - N * dot(N, g)));
            if (mode == kModeProceduralNormals) return vec4(Np * 0.5f + vec3(0.5f), 0.0f);
            if (mode == kModeClearcoatProcedural) return vec4(clearcoatFragment(albedo, Np, v, ambientE, m, f), 0.0f);
            specP = methodSpecular(Np, normalize(MUCOSA_LIGHT_POSITION(f) - v.P), normalize(f.eye - v.P), sigma2,
                                   m.shininess);
        }
        return vec4(albedo * (ambientE + v.diffuseLight), (v.specular * specP + v.sheen) * specularGate(v));
    }
    if (mode == kModeClearcoat) {
        // The map's normal in the tangent frame is the coat's. With specular
        // anti-aliasing the map comes from its mips, as an engine samples a
        // mipmapped normal texture; glTF has no lobe widening, so the mips'
        // slope variance is unused.
        vec3 Nm = decodeReflectanceNormal(mapRgb, m.bumpScale);
        return vec4(clearcoatFragment(albedo, normalize(Nm.x * v.T + Nm.y * v.B + Nm.z * v.N), v, ambientE, m, f),
                    0.0f);
    }
    if (mode == kModeDiffuse) {
        return vec4(albedo * (ambientE + v.diffuseLight), 0.0f);
    }
    if (mode == kModeBrdf) {
        return vec4(albedoTex * v.diffuseLight, 0.0f);
    }
    if (mode == kModeBrdfNoise) {
        vec3 Nb = decodeReflectanceNormal(mapRgb, m.bumpScale);
        float specB = methodSpecular(Nb, normalize(MUCOSA_LIGHT_T(v)), normalize(v.Vt),
                                     mapSampleVariance(mapSample, m, f), m.shininess);
        return vec4(albedoTex * v.diffuseLight, v.specular * specB * specularGate(v));
    }
    if (mode == kModeVertexPhong) {
        return vec4(albedo * (ambientE + v.diffuseLight), v.specular * specularGate(v));
    }
    if (mode == kModeMultitexture) {
        return vec4(albedo * (ambientE + v.diffuseLight), v.specular * highlight * specularGate(v));
    }
    if (mode == kModeNormals) {
        vec3 Nm = decodeReflectanceNormal(mapRgb, m.bumpScale);
        vec3 Nw = normalize(Nm.x * v.T + Nm.y * v.B + Nm.z * v.N);
        return vec4(Nw * 0.5f + vec3(0.5f), 0.0f);
    }
    if (mode == kModeTangents) {
        return vec4(normalize(v.T) * 0.5f + vec3(0.5f), 0.0f);
    }
    if (mode == kModeUv) {
        return vec4(fract(v.uv.x), fract(v.uv.y), 0.0f, 0.0f);
    }
    float r = depthRatio(length(v.Vt), m.depthMin, m.depthMax);
    return vec4(vec3(1.0f - r), 0.0f);
}

vec3 tissueFragment(Varyings v, vec3 albedoTex, vec4 mapSample, float highlight, float footprint, Material m,
                    Procedural pr, Frame f, int mode) {
    vec4 parts = tissueFragmentParts(v, albedoTex, mapSample, highlight, footprint, m, pr, f, mode);
    return vec3(parts) + vec3(parts.w);
}
