// camera_post.frag: the endoscope's camera (camera.glsl) on the linear HDR
// radiance the surface pass wrote. The renderer prepends "#version 330 core"
// and camera.glsl. The C++ reference does the same loop
// (src/shading/reference.cpp, applyCamera).
uniform Camera uCamera;
uniform sampler2D uHdr;  // linear radiance, RGBA16F, the frame's size

out vec4 fragColor;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(uHdr, p, 0).rgb;
    vec3 radiance = c;
    // The point-spread function over the 5 x 5 neighbourhood, clamped at the edges.
    if (uCamera.softness > 0.0) {
        ivec2 last = textureSize(uHdr, 0) - ivec2(1);
        vec3 sum = vec3(0.0);
        float weights = 0.0;
        for (int dy = -kSoftRadius; dy <= kSoftRadius; ++dy)
            for (int dx = -kSoftRadius; dx <= kSoftRadius; ++dx) {
                float w = psfWeight(dx, dy, uCamera.softness);
                sum += w * texelFetch(uHdr, clamp(p + ivec2(dx, dy), ivec2(0), last), 0).rgb;
                weights += w;
            }
        radiance = sum / weights;
    }
    fragColor = vec4(cameraPixel(radiance, p.x, p.y, uCamera), 1.0);
}
