// surface_tissue.frag: every shading mode's fragment stage. Samples the
// textures the mode reads (the only part the C++ reference does differently:
// it has its own sampler, shading::sampleTexture in src/shading/reference.cpp)
// and calls tissueFragment().
// Textures are uploaded with the file's first row at v = 1 (render/renderer.cpp).
// The procedural mode reads no texture besides the diffuse one: its noise
// needs only the permutation (uPerm, see the renderer's prelude). The renderer
// prepends the varyings (an "in" per member of Varyings, and readVaryings()).
uniform Material uMaterial;
uniform Frame uFrame;
uniform Procedural uProcedural;
uniform sampler2D uDiffuse;      // subject texture (RGB)
uniform sampler2D uReflectance;  // reflectance map, rgb = 0.5 N + 0.5, a = slope deviation (mips)
uniform sampler2D uHighlight;    // multitexture: sphere-mapped highlight (R)
uniform int uSplit;              // 1: the body light in rgb, the specular in alpha (scatter.frag reads them)

out vec4 fragColor;

void main() {
    Varyings v = readVaryings();
    vec3 albedoTex = vec3(1.0f);
    vec4 mapSample = vec4(0.5f, 0.5f, 1.0f, 0.0f);
    float highlight = 0.0f;
    if (modeReadsDiffuse(MUCOSA_MODE))
        albedoTex = texture(uDiffuse, diffuseCoord(v.uv, uFrame)).rgb;
    if (modeReadsReflectanceMap(MUCOSA_MODE)) {
        // Anti-aliased: the filtered mip chain and its slope variance
        // (Toksvig); otherwise the full-resolution map, as the paper sampled
        // it (the renderer then sets the texture's minification filter to
        // level 0 only, so one lookup serves both).
        vec2 mc = reflectanceMapCoord(v.uv, uMaterial);
        mapSample = texture(uReflectance, mc);
    }
    float footprint = 0.0f;
    if (modeIsProcedural(MUCOSA_MODE)) {
        vec3 q = proceduralCoord(v, uMaterial, uProcedural);
        footprint = noiseFootprint(dFdx(q), dFdy(q));
    }
    if (modeReadsHighlight(MUCOSA_MODE))
        highlight = texture(uHighlight, v.sphereUv).r;
    vec4 parts =
        tissueFragmentParts(v, albedoTex, mapSample, highlight, footprint, uMaterial, uProcedural, uFrame, MUCOSA_MODE);
    // Linear radiance for the camera's HDR target or a float framebuffer, or
    // display values (an RGBA8 target clamps them to [0, 1]).
    if (uSplit != 0)
        fragColor = clamp(parts, 0.0f, kHalfMax);
    else
        fragColor = vec4(clamp(parts.rgb + vec3(parts.a), 0.0f, kHalfMax), 1.0f);
}
