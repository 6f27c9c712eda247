// scatter.frag: the sub-surface scattering (scatter.glsl) over a perspective
// image: the HDR target, or the wide face or a cube face a lens reads. Three
// passes (uPass), the diffusion at half the image's size (it is a blur: a
// quarter of the pixels carry it, and on a software rasteriser that is the
// difference between affordable and not):
//   0: along x, from the full-size body light into a half-size image
//      (rgb, and the centre's eye depth in alpha; 0 where no surface);
//   1: along y, half size to half size;
//   2: full size: the body light's share that diffuses, upsampled from the
//      half-size result by depth (neighbours across a silhouette do not
//      count), plus the share that does not, plus the specular.
// The renderer prepends "#version 330 core" and scatter.glsl; the C++
// reference (shading::applyScatter) takes the same steps.
uniform sampler2D uSource;  // passes 0 and 2: body light (rgb), specular (a), full size
uniform sampler2D uDepth;   // window depth, full size: 1 where no surface, 0 outside the scope's mask
uniform sampler2D uHalf;    // passes 1 and 2: the previous pass's half-size image
uniform ivec4 uRect;        // the drawn pixels, full size: x0, y0, x1, y1 (exclusive)
uniform int uPass;
uniform vec2 uFocalPx;     // the projection's focal lengths along x and y, full-size pixels
uniform vec2 uProjection;  // P[2][2], P[3][2]
uniform float uShare;      // the share of the body light that diffuses
uniform float uOffsetMm[kScatterTaps];
uniform vec3 uWeight[kScatterTaps];

out vec4 fragColor;

float depthAt(ivec2 q) {
    return scatterSurfaceDepth(texelFetch(uDepth, q, 0).r, uProjection.x, uProjection.y);
}

bool insideRect(ivec2 q, ivec4 r) {
    return q.x >= r.x && q.y >= r.y && q.x < r.z && q.y < r.w;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec4 halfRect = scatterHalfRect(uRect);
    if (uPass == 0) {
        ivec2 p0 = clamp(2 * p, uRect.xy, uRect.zw - ivec2(1));
        vec3 c = texelFetch(uSource, p0, 0).rgb;
        float zc = depthAt(p0);
        vec3 body = c;
        if (zc > 0.0) {
            body = vec3(0.0);
            for (int i = 0; i < kScatterTaps; ++i) {
                ivec2 q = p0 + ivec2(scatterOffsetPx(uOffsetMm[i], uFocalPx.x, zc), 0);
                vec3 s = c;
                if (insideRect(q, uRect) && scatterAccepts(zc, depthAt(q), uOffsetMm[i]))
                    s = texelFetch(uSource, q, 0).rgb;
                body += uWeight[i] * s;
            }
        }
        fragColor = vec4(body, zc);
    } else if (uPass == 1) {
        vec4 c = texelFetch(uHalf, p, 0);
        vec3 body = c.rgb;
        if (c.a > 0.0) {
            body = vec3(0.0);
            for (int i = 0; i < kScatterTaps; ++i) {
                ivec2 q = p + ivec2(0, scatterOffsetPx(uOffsetMm[i], 0.5 * uFocalPx.y, c.a));
                vec3 s = c.rgb;
                if (insideRect(q, halfRect)) {
                    vec4 t = texelFetch(uHalf, q, 0);
                    if (scatterAccepts(c.a, t.a, uOffsetMm[i])) s = t.rgb;
                }
                body += uWeight[i] * s;
            }
        }
        fragColor = vec4(body, c.a);
    } else {
        vec4 c = texelFetch(uSource, p, 0);
        float zc = depthAt(p);
        vec3 scattered = c.rgb;
        if (zc > 0.0) {
            // The four half-size pixels around p, bilinearly, those on p's surface only.
            vec2 hp = (vec2(p) + vec2(0.5)) * 0.5 - vec2(0.5);
            ivec2 i0 = ivec2(floor(hp));
            vec2 f = hp - floor(hp);
            vec3 sum = vec3(0.0);
            float weights = 0.0;
            for (int k = 0; k < 4; ++k) {
                ivec2 d = ivec2(k & 1, k >> 1);
                ivec2 q = clamp(i0 + d, halfRect.xy, halfRect.zw - ivec2(1));
                vec4 t = texelFetch(uHalf, q, 0);
                float w = scatterBilinear(f, d.x, d.y);
                if (w > 0.0 && scatterAccepts(zc, t.a, scatterUpsampleMm(zc, uFocalPx.x))) {
                    sum += w * t.rgb;
                    weights += w;
                }
            }
            if (weights > 0.0) scattered = sum / weights;
        }
        fragColor = vec4(scatterMix(scattered, c.rgb, uShare) + vec3(c.a), 1.0);
    }
}
