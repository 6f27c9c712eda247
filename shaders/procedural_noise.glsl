// procedural_noise.glsl: Perlin's improved noise and its fractal sums, with
// analytic gradients, at run time (the paper's "future work": noise moved
// from pre-processing to the interactive stage).
//
// Compiled twice like common_shading.glsl: as GLSL 3.30 (the renderer
// prepends it) and as C++20 with glm (src/shading/glsl.hpp). The caller
// provides int permAt(int i), the permutation of the noise module
// (noise::Permutation, indices modulo 256), and int permPairAt(int i) =
// permAt(i) | permAt(i + 1) << 8; in GLSL both read one uniform array (the
// pairs), so the procedural path needs no texture at all. Same lattice, hashes, fade,
// gradients and octave sums as src/noise (perlin.cpp, fractal.cpp): the GL
// values agree with mucosa::noise to float precision (tests/render/
// gpu_noise_test.cpp). Notation: docs/theory.md, "Procedural noise".

// Octave limit of the fractal sums (noise::validate allows 1..32).
const int kMaxOctaves = 32;
// Var(dn/dx) of improved noise over uniformly distributed 3D points
// (noise::perlinGradientComponentVariance(), checked by a test): the slope
// variance one octave of unit amplitude and frequency carries. (A fixed
// slice z = const varies by about 12 %: 0.424 at z = 0.5, 0.51 at z = 0.1.)
const float kNoiseSlopeVariance = 0.48196f;
// Anti-aliasing: an octave fades out as its nominal frequency goes from
// kFadeStart to kFadeEnd cycles per pixel. An octave of improved noise
// carries energy up to ~1.5x its nominal frequency, so it starts to alias
// (pass the Nyquist limit of 0.5) from ~0.33 and is mostly aliased by 0.7.
const float kFadeStart = 0.35f;
const float kFadeEnd = 0.7f;

// Perlin 2002: 6t^5 - 15t^4 + 10t^3 and its derivative 30 t^2 (t - 1)^2.
float noiseFade(float t) {
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}
float noiseFadeDerivative(float t) {
    return 30.0f * t * t * (t * (t - 2.0f) + 1.0f);
}
float noiseLerp(float t, float a, float b) {
    return a + t * (b - a);
}

// The reference's grad(hash, x, y, z) = g . (x, y, z) and its vector g: for
// h = hash & 15, u = x if h < 8 else y (sign: bit 0), v = y if h < 4, x if h
// is 12 or 14, else z (sign: bit 1). Each component of g is in {-1, 0, 1}
// and stored for all 16 hashes as 2-bit codes (value + 1) in one constant, so
// the gradient costs a shift and a mask per component and no branches (SIMD
// rasterisers such as llvmpipe evaluate every side of a branch).
const int kGradCodesX = 0x46552222;  // x of g for h = 15 .. 0, two bits each
const int kGradCodesY = 0x2222550a;
const int kGradCodesZ = 0x190a0a55;
vec3 noiseGradientVector(int hash) {
    int sh = (hash & 15) * 2;
    return vec3(float((kGradCodesX >> sh) & 3), float((kGradCodesY >> sh) & 3), float((kGradCodesZ >> sh) & 3)) -
           vec3(1.0f);
}

// A lattice cell index reduced modulo the period (1..256; 256 = plain noise).
int noiseWrap(float cell, float period) {
    return int(cell - period * floor(cell / period));
}

// Improved noise at p with its gradient, vec4(n, dn/dx, dn/dy, dn/dz), given
// p's cell (floor(p)) and the hashes of its eight corners: hA at (0, 0, 0),
// then x fastest, y, z (hH at (1, 1, 1)).
vec4 perlinNoiseGradientHashed(vec3 p, vec3 cell, int hA, int hB, int hC, int hD, int hE, int hF, int hG, int hH) {
    float x = p.x - cell.x;
    float y = p.y - cell.y;
    float z = p.z - cell.z;
    vec3 gA = noiseGradientVector(hA), gB = noiseGradientVector(hB);
    vec3 gC = noiseGradientVector(hC), gD = noiseGradientVector(hD);
    vec3 gE = noiseGradientVector(hE), gF = noiseGradientVector(hF);
    vec3 gG = noiseGradientVector(hG), gH = noiseGradientVector(hH);
    float a = dot(gA, vec3(x, y, z)), b = dot(gB, vec3(x - 1.0f, y, z));
    float c = dot(gC, vec3(x, y - 1.0f, z)), d = dot(gD, vec3(x - 1.0f, y - 1.0f, z));
    float e = dot(gE, vec3(x, y, z - 1.0f)), f = dot(gF, vec3(x - 1.0f, y, z - 1.0f));
    float g = dot(gG, vec3(x, y - 1.0f, z - 1.0f)), h = dot(gH, vec3(x - 1.0f, y - 1.0f, z - 1.0f));
    float u = noiseFade(x), v = noiseFade(y), w = noiseFade(z);
    float x1 = noiseLerp(u, a, b), x2 = noiseLerp(u, c, d);
    float x3 = noiseLerp(u, e, f), x4 = noiseLerp(u, g, h);
    float y1 = noiseLerp(v, x1, x2), y2 = noiseLerp(v, x3, x4);
    float n = noiseLerp(w, y1, y2);
    // Gradient: the corner gradients blended as the values are, plus the
    // fade's derivative times the difference along each axis.
    vec3 blend = mix(mix(mix(gA, gB, u), mix(gC, gD, u), v), mix(mix(gE, gF, u), mix(gG, gH, u), v), w);
    float dx = blend.x + noiseFadeDerivative(x) * noiseLerp(w, noiseLerp(v, b - a, d - c), noiseLerp(v, f - e, h - g));
    float dy = blend.y + noiseFadeDerivative(y) * noiseLerp(w, x2 - x1, x4 - x3);
    float dz = blend.z + noiseFadeDerivative(z) * (y2 - y1);
    return vec4(n, dx, dy, dz);
}

// The same, given the lattice indices of the corners (any periods): the
// reference's hashes (Perlin 2002, with the periodic wrap of perlinPeriodic),
// fourteen lookups.
vec4 perlinNoiseGradientAt(vec3 p, vec3 cell, int X0, int Y0, int Z0, int X1, int Y1, int Z1) {
    int A = permAt(X0) + Y0;
    int B = permAt(X1) + Y0;
    int A1 = permAt(X0) + Y1;
    int B1 = permAt(X1) + Y1;
    return perlinNoiseGradientHashed(p, cell, permAt(permAt(A) + Z0), permAt(permAt(B) + Z0),
                                     permAt(permAt(A1) + Z0), permAt(permAt(B1) + Z0), permAt(permAt(A) + Z1),
                                     permAt(permAt(B) + Z1), permAt(permAt(A1) + Z1), permAt(permAt(B1) + Z1));
}

// Improved noise at p on a lattice that wraps with the given periods (1..256
// per axis; 256 = plain noise): noise::perlinPeriodicGradient.
vec4 perlinNoiseGradient(vec3 p, vec3 period) {
    vec3 cell = floor(p);
    int X0 = noiseWrap(cell.x, period.x);
    int Y0 = noiseWrap(cell.y, period.y);
    int Z0 = noiseWrap(cell.z, period.z);
    int X1 = X0 + 1 == int(period.x) ? 0 : X0 + 1;
    int Y1 = Y0 + 1 == int(period.y) ? 0 : Y0 + 1;
    int Z1 = Z0 + 1 == int(period.z) ? 0 : Z0 + 1;
    return perlinNoiseGradientAt(p, cell, X0, Y0, Z0, X1, Y1, Z1);
}

// The same hashes in fewer lookups: permPairAt(i) is perm[i] | perm[i + 1] << 8
// (indices modulo 256), so where an index and its successor are both needed
// one lookup serves (on llvmpipe, which gathers uniform-array elements lane by
// lane, the lookups were half the cost of an octave; bench_render).
//
// A z slice (p.z the same for every point, as in a map's texture-space sum):
// noise periodic in x and y (periods 1..256; 256 = plain) and plain along z.
// x pairs (X1 = X0 + 1, or 0 where a periodic lattice wraps: perm[0], a
// constant index), and permSlicePairAt(j, Z0) = permPairAt(permAt(j) + Z0),
// which the renderer tabulates for the frame's Z0 (one uniform array of 256
// pairs), makes the last two hash levels one lookup: 5 per octave instead of
// 14. The same hashes, so the same values as perlinNoiseGradient.
vec4 perlinNoiseGradientSlice(vec3 p, vec2 period) {
    vec3 cell = floor(p);
    int X0 = noiseWrap(cell.x, period.x);
    int Y0 = noiseWrap(cell.y, period.y);
    int Z0 = int(cell.z) & 255;
    int X1 = X0 + 1 == int(period.x) ? 0 : X0 + 1;
    int Y1 = Y0 + 1 == int(period.y) ? 0 : Y0 + 1;
    int px = permPairAt(X0);
    int pX0 = px & 255;
    int pX1 = X1 == 0 ? permAt(0) : px >> 8;
    int hAE = permSlicePairAt(pX0 + Y0, Z0), hBF = permSlicePairAt(pX1 + Y0, Z0);
    int hCG = permSlicePairAt(pX0 + Y1, Z0), hDH = permSlicePairAt(pX1 + Y1, Z0);
    return perlinNoiseGradientHashed(p, cell, hAE & 255, hBF & 255, hCG & 255, hDH & 255, hAE >> 8, hBF >> 8,
                                     hCG >> 8, hDH >> 8);
}

// Plain improved noise (noise::perlinGradient), the same values as period 256
// for less work: Perlin's floor(x) & 255, cell + 1 unreduced as the
// reference indexes its doubled table (the lookups wrap), and every index
// with its successor in one permPairAt: 7 lookups instead of 14.
vec4 perlinNoiseGradient(vec3 p) {
    vec3 cell = floor(p);
    int X0 = int(cell.x) & 255;
    int Y0 = int(cell.y) & 255;
    int Z0 = int(cell.z) & 255;
    int px = permPairAt(X0);
    int pa = permPairAt((px & 255) + Y0), pb = permPairAt((px >> 8) + Y0);
    int hAE = permPairAt((pa & 255) + Z0), hBF = permPairAt((pb & 255) + Z0);
    int hCG = permPairAt((pa >> 8) + Z0), hDH = permPairAt((pb >> 8) + Z0);
    return perlinNoiseGradientHashed(p, cell, hAE & 255, hBF & 255, hCG & 255, hDH & 255, hAE >> 8, hBF >> 8,
                                     hCG >> 8, hDH >> 8);
}

// Fractal-sum settings: the reflectance map's parameters (reflectance::MapParams,
// the same registry as `mucosa map`), packed by shading::glsl::packProcedural.
struct Procedural {
    float frequency;   // cycles of the base octave per map width
    int octaves;
    float lacunarity;
    float gain;
    float z;           // the slice of 3D noise a map samples
    int turbulence;    // 1: sum |n|
    int tileable;      // 1: periodic lattice, one map width per period (as the map)
    float strength;    // slope scale: Hu = strength dH/du, u in map widths
    int space;         // 0: texture (UV) space, 1: object space (solid noise)
    float scaleMm;     // object space: mm of surface per map width
    int antialias;     // 1: octaves fade out at the pixel footprint
    float texels;      // detail of a map this many texels wide (its normal filter); 0 = unlimited
};

const int kSpaceUv = 0;
const int kSpaceObject = 1;

// Shader specialisation: the renderer compiles the procedural mode once per
// (octaves, space, tileable, turbulence) with these as constants, so the
// octave loop has a fixed trip count and the per-octave branches fold away
// (~20 % faster on llvmpipe). Without the defines (the C++ reference, the GPU
// noise evaluator) they read the uniforms.
#ifdef MUCOSA_PROCEDURAL_OCTAVES
#define MUCOSA_PR_OCTAVES(pr) MUCOSA_PROCEDURAL_OCTAVES
#define MUCOSA_PR_SPACE(pr) MUCOSA_PROCEDURAL_SPACE
#define MUCOSA_PR_TILEABLE(pr) MUCOSA_PROCEDURAL_TILEABLE
#define MUCOSA_PR_TURBULENCE(pr) MUCOSA_PROCEDURAL_TURBULENCE
#else
#define MUCOSA_PR_OCTAVES(pr) pr.octaves
#define MUCOSA_PR_SPACE(pr) pr.space
#define MUCOSA_PR_TILEABLE(pr) pr.tileable
#define MUCOSA_PR_TURBULENCE(pr) pr.turbulence
#endif

// The slope response of the map's normals (central differences over one
// texel, reflectance::encodeNormals8) to one octave of f cycles per map width
// on a map `texels` wide: the RMS ratio of the differenced to the true slope
// of improved noise, with s = f / texels lattice cells per texel,
// g^2 = 1 - 5.5 s^2 / (1 + 4.49 s^2) (fitted to measurements within 0.01 for
// s <= 0.5, tests/shading/procedural_test.cpp; 0.59 at the map's Nyquist
// s = 1/2, ~0 at s = 1). The procedural path scales each octave's slope by
// it, so that for equal parameters both paths have the same slope energy
// per octave and look alike.
float mapSlopeResponse(float f, float texels) {
    if (texels <= 0.0f) return 1.0f;
    float s2 = (f / texels) * (f / texels);
    return sqrt(max(1.0f - 5.5f * s2 / (1.0f + 4.49f * s2), 0.0f));
}

// A fractal sum at q with its gradient, and the slope variance of the
// octaves the footprint faded out.
struct FractalSample {
    vec4 h;               // (H, dH/dq)
    float fadedVariance;  // per-axis slope variance removed by anti-aliasing (before strength)
};

// H(q) = sum_i gain^i n(f_i q): in texture space q = (u, v) of the map and
// n(f_i u, f_i v, z) (the map's sum, noise::fractal); in object space q is a
// 3D point in map widths (noise::solidFractalGradient). `footprint` is the
// size of a pixel in units of q; 0 turns the fade off.
FractalSample fractalNoise(vec3 q, float footprint, Procedural pr) {
    FractalSample s;
    s.h = vec4(0.0f);
    s.fadedVariance = 0.0f;
    float f = pr.frequency;
    float a = 1.0f;
    // With lacunarity >= 1 the octaves' frequencies never fall, so once an
    // octave is faded out (or beyond the map's response) so are all finer
    // ones: the loop stops there, and the second loop below adds what they
    // would have added (their slope variance). Same values; but a SIMD
    // rasteriser leaves the loop as soon as every pixel of a block has (distant
    // walls), and a GPU as soon as a warp has.
    bool monotone = pr.lacunarity >= 1.0f;
    int i = 0;
    for (; i < kMaxOctaves; ++i) {
        if (i >= MUCOSA_PR_OCTAVES(pr)) break;
        float weight = 1.0f;
        if (pr.antialias != 0) weight = 1.0f - smoothstep(kFadeStart, kFadeEnd, f * footprint);
        float slopeGain = mapSlopeResponse(f, pr.texels);
        if (monotone && (weight <= 0.0f || slopeGain <= 0.0f)) break;
        if (weight > 0.0f && slopeGain > 0.0f) {
            vec4 n;
            if (MUCOSA_PR_SPACE(pr) == kSpaceUv) {
                float per = 256.0f;
                if (MUCOSA_PR_TILEABLE(pr) != 0) per = f > 256.0f ? 256.0f : floor(f);
                n = perlinNoiseGradientSlice(vec3(f * q.x, f * q.y, pr.z), vec2(per, per));
                n.w = 0.0f;  // the slice z is fixed
            } else {
                n = perlinNoiseGradient(q * f);
            }
            if (MUCOSA_PR_TURBULENCE(pr) != 0 && n.x < 0.0f) n = -n;
            float k = a * f * slopeGain;
            s.h = s.h + weight * vec4(a * n.x, k * n.y, k * n.z, k * n.w);
        }
        s.fadedVariance = s.fadedVariance + (1.0f - weight * weight) * (a * f * slopeGain) * (a * f * slopeGain);
        f = f * pr.lacunarity;
        a = a * pr.gain;
    }
    for (; i < kMaxOctaves; ++i) {
        if (i >= MUCOSA_PR_OCTAVES(pr)) break;
        float k = a * f * mapSlopeResponse(f, pr.texels);
        s.fadedVariance = s.fadedVariance + k * k;  // weight 0
        f = f * pr.lacunarity;
        a = a * pr.gain;
    }
    s.fadedVariance = s.fadedVariance * kNoiseSlopeVariance;
    return s;
}
