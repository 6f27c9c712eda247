// surface_tissue.frag: every shading mode's fragment stage. Samples the
// textures (the only part the C++ reference does differently: it has its own
// sampler, src/shading/sampler.cpp) and calls tissueFragment().
// Textures are uploaded with the file's first row at v = 1 (render/textures.cpp).
uniform Material uMaterial;
uniform sampler2D uDiffuse;      // subject texture (RGB)
uniform sampler2D uReflectance;  // reflectance map, rgb = 0.5 N + 0.5
uniform sampler2D uHighlight;    // multitexture: sphere-mapped highlight (R)

in vec3 vLt;
in vec3 vVt;
in vec2 vUv;
in vec3 vT;
in vec3 vB;
in vec3 vN;
in float vDiffuseLight;
in float vSpecular;
in vec2 vSphereUv;

out vec4 fragColor;

void main() {
    Varyings v;
    v.Lt = vLt;
    v.Vt = vVt;
    v.uv = vUv;
    v.T = vT;
    v.B = vB;
    v.N = vN;
    v.diffuseLight = vDiffuseLight;
    v.specular = vSpecular;
    v.sphereUv = vSphereUv;
    vec3 albedoTex = vec3(1.0f);
    vec3 mapRgb = vec3(0.5f, 0.5f, 1.0f);
    float highlight = 0.0f;
    if (MUCOSA_MODE != kModeNormals && MUCOSA_MODE != kModeTangents && MUCOSA_MODE != kModeUv &&
        MUCOSA_MODE != kModeDepth)
        albedoTex = texture(uDiffuse, vUv).rgb;
    if (MUCOSA_MODE == kModeNoise || MUCOSA_MODE == kModeNormals || MUCOSA_MODE == kModeBrdfNoise)
        mapRgb = texture(uReflectance, reflectanceMapCoord(vUv, uMaterial)).rgb;
    if (MUCOSA_MODE == kModeMultitexture)
        highlight = texture(uHighlight, vSphereUv).r;
    vec3 color = tissueFragment(v, albedoTex, mapRgb, highlight, uMaterial, MUCOSA_MODE);
    fragColor = vec4(clamp(color, 0.0f, 1.0f), 1.0f);
}
