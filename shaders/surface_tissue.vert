// surface_tissue.vert: every shading mode's vertex stage. The renderer
// prepends "#version 330 core", "#define MUCOSA_MODE <k>", the permutation
// uniform, procedural_noise.glsl, common_shading.glsl and the varyings (an
// "out" per member of Varyings, and writeVaryings(); src/render/uniforms.cpp);
// the work is in tissueVertex().
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec4 aTangent;
layout(location = 3) in vec2 aUv;
layout(location = 4) in vec3 aTint;  // the mesh's per-vertex colour (white without)

uniform Frame uFrame;
uniform Material uMaterial;

void main() {
    Varyings v = tissueVertex(aPosition, aNormal, aTangent, aUv, aTint, uFrame, uMaterial, MUCOSA_MODE);
    writeVaryings(v);
    gl_Position = tissueClipPosition(aPosition, uFrame);
}
