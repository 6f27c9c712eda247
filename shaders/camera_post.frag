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
    // The point-spread function over the 3 x 3 neighbourhood, clamped at the edges.
    if (uCamera.softness > 0.0) {
        ivec2 last = textureSize(uHdr, 0) - ivec2(1);
        ivec2 lo = max(p - ivec2(1), ivec2(0)), hi = min(p + ivec2(1), last);
        vec3 a = texelFetch(uHdr, ivec2(lo.x, p.y), 0).rgb + texelFetch(uHdr, ivec2(hi.x, p.y), 0).rgb +
                 texelFetch(uHdr, ivec2(p.x, lo.y), 0).rgb + texelFetch(uHdr, ivec2(p.x, hi.y), 0).rgb;
        vec3 d = texelFetch(uHdr, lo, 0).rgb + texelFetch(uHdr, ivec2(hi.x, lo.y), 0).rgb +
                 texelFetch(uHdr, ivec2(lo.x, hi.y), 0).rgb + texelFetch(uHdr, hi, 0).rgb;
        radiance = psfFilter(c, a, d, psfWeights(uCamera.softness));
    }
    fragColor = vec4(cameraPixel(radiance, p.x, p.y, uCamera), 1.0);
}
