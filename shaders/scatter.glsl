// scatter.glsl: sub-surface scattering in screen space (docs/theory.md,
// "Light under the mucosa"). Light that enters the mucosa leaves it again
// around where it entered, spread by a diffusion profile: Burley's normalised
// diffusion (Christensen & Burley 2015), R(r) = (e^(-r/d) + e^(-r/3d)) /
// (8 pi d r) per channel, whose integral over the plane is 1 (no light is made
// or lost). The diffusion runs at half the image's size (scatter.frag).
// Mucosa is layered: a share of the body light (material.
// scatter_share) diffuses through the lamina propria, and the rest leaves
// the thin epithelium near where it entered, keeping the fine detail of what
// lies above the diffusion. The surface pass writes the body's diffuse
// radiance (rgb) apart from the light the film reflects (the white specular,
// alpha); two passes (scatter.frag), along x then y, convolve the body light
// with the profile's marginal, K(x) = (K0(|x|/d) + K0(|x|/3d)) /
// (4 pi d), at taps placed in millimetres on the surface and turned into
// pixels by the pixel's depth. Two 1D passes of the marginal give the 2D
// profile's exact response to any straight edge (the separable approximation
// of Jimenez et al. 2015). Like camera.glsl it is compiled twice: as GLSL 3.30
// and as C++20 with glm (src/shading/glsl.hpp), so the renderer and the C++
// reference take the same taps.

// Taps per pass: the centre and kScatterSide on each side. Their offsets (mm)
// and per-channel weights (the marginal integrated over each tap's interval,
// normalised per channel) come from shading::scatterKernel.
const int kScatterSide = 5;
const int kScatterTaps = 2 * kScatterSide + 1;
// Light diffuses under a continuous surface, not across a silhouette: a tap
// counts where its depth differs from the centre's by no more than a surface
// inclined at atan(kScatterMaxSlope) = 72 degrees to the image plane would
// (plus 1 % of the depth); elsewhere, and beyond the image (where nothing
// is known), the centre's own light stands in.
const float kScatterMaxSlope = 3.0f;

// Eye depth (mm along the view axis) of window depth w in [0, 1] for an
// OpenGL perspective projection with P[2][2] = a, P[3][2] = b.
float eyeDepth(float w, float a, float b) {
    return b / ((2.0f * w - 1.0f) + a);
}

// The eye depth of a pixel's surface, or 0 where there is none: window depth
// 1 (nothing drawn) or 0 (the occluder outside the scope's mask).
float scatterSurfaceDepth(float w, float a, float b) {
    return w > 0.0f && w < 1.0f ? eyeDepth(w, a, b) : 0.0f;
}

// The half-size image's pixels for a full-size rectangle x0, y0, x1, y1
// (exclusive): half-size pixel P stands for full-size pixel 2P.
ivec4 scatterHalfRect(ivec4 r) {
    return ivec4(r.x / 2, r.y / 2, (r.z + 1) / 2, (r.w + 1) / 2);
}

// The bilinear weight of the half-size neighbour (dx, dy) in {0, 1}^2 at
// fraction f.
float scatterBilinear(vec2 f, int dx, int dy) {
    return (dx == 0 ? 1.0f - f.x : f.x) * (dy == 0 ? 1.0f - f.y : f.y);
}

// How far (mm) a half-size neighbour may lie from the full-size pixel it is
// read for: two full-size pixels at depth z.
float scatterUpsampleMm(float z, float focalPx) {
    return 2.0f * z / focalPx;
}

// A tap offsetMm from a pixel whose surface lies zc mm deep, in whole pixels
// of a projection with focal length focalPx (pixels) along the pass.
int scatterOffsetPx(float offsetMm, float focalPx, float zc) {
    return int(floor(offsetMm * focalPx / zc + 0.5f));
}

// The body light leaving a pixel: `share` of it diffused (scattered, the two
// passes' result), the rest where it entered (kept: the epithelium's single
// scattering, which keeps the fine detail of the vessels above the diffusion).
vec3 scatterMix(vec3 scattered, vec3 kept, float share) {
    return scattered * share + kept * (1.0f - share);
}

bool scatterAccepts(float zc, float zs, float offsetMm) {
    return zs > 0.0f && abs(zs - zc) <= kScatterMaxSlope * abs(offsetMm) + 0.01f * zc;
}
