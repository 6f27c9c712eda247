// surface_tissue.vert: every shading mode's vertex stage. The renderer
// prepends "#version 330 core", "#define MUCOSA_MODE <k>", the permutation
// uniform, procedural_noise.glsl and common_shading.glsl; the work is in tissueVertex().
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec4 aTangent;
layout(location = 3) in vec2 aUv;

uniform Frame uFrame;
uniform Material uMaterial;

out vec3 vLt;
out vec3 vVt;
out vec2 vUv;
out vec3 vT;
out vec3 vB;
out vec3 vN;
out float vDiffuseLight;
out float vSpecular;
out vec2 vSphereUv;
out vec3 vP;

void main() {
    Varyings v = tissueVertex(aPosition, aNormal, aTangent, aUv, uFrame, uMaterial, MUCOSA_MODE);
    vLt = v.Lt;
    vVt = v.Vt;
    vUv = v.uv;
    vT = v.T;
    vB = v.B;
    vN = v.N;
    vDiffuseLight = v.diffuseLight;
    vSpecular = v.specular;
    vSphereUv = v.sphereUv;
    vP = v.P;
    gl_Position = tissueClipPosition(aPosition, uFrame);
}
