// camera.glsl: the video bronchoscope's optics, sensor and processing, applied
// to the linear HDR radiance the surface shaders write (docs/theory.md, "The
// endoscope's camera"). Like common_shading.glsl it is compiled twice: as GLSL
// 3.30 (the post pass, camera_post.frag) and as C++20 with glm (the C++
// reference, src/shading/glsl.hpp), so both apply the same steps in the same
// order. Same subset of the two languages: f-suffixed literals, u-suffixed
// unsigned literals, no swizzles, no in/out parameters.
//
// Per pixel, in the order light meets them:
//   1. optics: a Gaussian point-spread function over 5 x 5 pixels (softness), natural
//      vignetting, cos^k of the field angle, and veiling glare: light the lenses scatter,
//      spread evenly over the sensor (camera.flare x the field's mean radiance);
//   2. exposure: the radiance times 2^EV (fixed, or from auto-exposure);
//   3. the sensor: Poisson-Gaussian noise (shot noise with variance
//      signal / full well, read noise with a fixed deviation), then clipping
//      at saturation, per channel, as a sensor clips;
//   4. the camera's processing: the response (tone curve: linear, BT.709 or
//      sRGB) with the highlight knee of video cameras, then the colour
//      enhancement of endoscopy video processors (a saturation gain about the
//      Rec. 709 luma);
//   5. the scope's field-of-view mask: a circle or an octagon, black outside.

// Tone curves (shading::ToneCurve, the registry's camera.tone_curve).
const int kToneLinear = 0;
const int kToneBt709 = 1;
const int kToneSrgb = 2;
// Field-of-view masks (camera.mask).
const int kMaskNone = 0;
const int kMaskCircle = 1;
const int kMaskOctagon = 2;
// The softness kernel is 5 x 5 taps: enough for sigma <= kSoftMax px (a tap
// 3 px away would weigh at most exp(-9 / 2.88) = 4 % of the centre). Real
// bronchoscopy video is this soft: the optics, the sensor's few pixels
// interpolated to the display's, and the video codec together.
const int kSoftRadius = 2;
const float kSoftMax = 1.2f;
// The renderer skips shading the pixels further than this outside the mask
// (camera_mask.frag): more than the PSF's reach, so no visible pixel changes.
const float kMaskMarginPx = 3.0f;

struct Camera {
    float exposure;         // 2^EV: sensor signal per unit of radiance (after auto-exposure)
    float vignettingPower;  // k of cos^k(field angle); 0 = off, 4 = the natural cos^4 law
    float tanHalfFovX;      // tan of half the horizontal field of view (the projection's)
    float tanHalfFovY;      // tan of half the vertical field of view
    float width;            // frame size in pixels
    float height;
    int mask;          // kMaskNone, kMaskCircle, kMaskOctagon
    float maskRadius;  // mask radius (inradius for the octagon) / half the smaller frame side
    float softness;    // sigma of the Gaussian PSF in pixels; 0 = sharp
    float fullWell;    // sensor signal 1 = this many photo-electrons; 0 = no noise
    float readNoise;   // deviation of the read noise, in units of the full signal
    int toneCurve;     // kToneLinear, kToneBt709, kToneSrgb
    int frameSeed;     // the noise pattern of this frame
    float saturation;  // colour gain about the luma after the tone curve; 1 = none
    float knee;        // the highlight knee's output level; 1 = none
    vec3 veil;         // veiling glare on the sensor: camera.flare x the field's mean radiance
};

// The PSF's weight of a tap dx, dy pixels from the centre, unnormalised:
// exp(-(dx^2 + dy^2) / (2 sigma^2)); sigma = 0 gives the centre alone. The
// caller sums the (2 kSoftRadius + 1)^2 taps and divides by the weights' sum.
float psfWeight(int dx, int dy, float sigma) {
    float r2 = float(dx * dx + dy * dy);
    if (sigma <= 0.0f) return r2 == 0.0f ? 1.0f : 0.0f;
    return exp(-r2 / (2.0f * sigma * sigma));
}

// Natural vignetting at pixel centre (px, py) (pixels from the bottom-left
// corner): the angle theta between the ray and the optical axis of the
// rectilinear projection, cos(theta)^k (k = 4: the cos^4 law of a thin lens).
float vignetting(float px, float py, Camera c) {
    float x = (2.0f * px / c.width - 1.0f) * c.tanHalfFovX;
    float y = (2.0f * py / c.height - 1.0f) * c.tanHalfFovY;
    float cos2 = 1.0f / (1.0f + x * x + y * y);
    return pow(cos2, 0.5f * c.vignettingPower);
}

// Coverage of pixel (px, py) by the field-of-view mask, anti-aliased over one
// pixel: 1 inside, 0 outside.
float fovMask(float px, float py, Camera c) {
    if (c.mask == kMaskNone) return 1.0f;
    float halfSide = 0.5f * min(c.width, c.height);
    float x = abs(px - 0.5f * c.width);
    float y = abs(py - 0.5f * c.height);
    // Distance-like measure in pixels: Euclidean for the circle; for a
    // regular octagon with inradius R, the largest of the four support
    // functions max(|x|, |y|, (|x| + |y|) / sqrt(2)).
    float d = sqrt(x * x + y * y);
    if (c.mask == kMaskOctagon) d = max(max(x, y), (x + y) * 0.70710678f);
    return clamp(c.maskRadius * halfSide - d + 0.5f, 0.0f, 1.0f);
}

// A 32-bit integer hash (PCG's output permutation; Jarzynski & Olano 2020,
// "Hash functions for GPU rendering"): the sensor noise's random numbers, the
// same on the GPU and in C++.
uint pcgHash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in (0, 1) from a hash.
float hashUniform(uint h) {
    return (float(h >> 8u) + 0.5f) * (1.0f / 16777216.0f);
}

// Three independent standard normal deviates for pixel (ix, iy) in frame
// `seed`, one per channel: Box-Muller on four hashed uniforms (two pairs, each
// giving a cosine and a sine deviate; the fourth is not used).
vec3 pixelGaussians(int ix, int iy, int seed) {
    uint h = pcgHash(uint(ix) + pcgHash(uint(iy) + pcgHash(uint(seed))));
    uint h2 = pcgHash(h);
    uint h3 = pcgHash(h2);
    uint h4 = pcgHash(h3);
    float r1 = sqrt(-2.0f * log(hashUniform(h)));
    float a1 = 6.2831853f * hashUniform(h2);
    float r2 = sqrt(-2.0f * log(hashUniform(h3)));
    float a2 = 6.2831853f * hashUniform(h4);
    return vec3(r1 * cos(a1), r1 * sin(a1), r2 * cos(a2));
}

// Poisson-Gaussian sensor noise (Foi et al. 2008): the variance of a pixel
// with mean signal s is s / fullWell + readNoise^2 (the mean-variance line),
// drawn as a Gaussian (the Poisson's normal limit at the counts of a sensor).
// g: the pixel's standard normal deviate for this channel.
float sensorNoise(float s, float g, Camera c) {
    float shot = c.fullWell > 0.0f ? max(s, 0.0f) / c.fullWell : 0.0f;
    return s + sqrt(shot + c.readNoise * c.readNoise) * g;
}

// The camera's response to a clipped sensor signal s in [0, 1].
float toneCurve(float s, int curve) {
    if (curve == kToneBt709) return s < 0.018f ? 4.5f * s : 1.099f * pow(s, 0.45f) - 0.099f;
    if (curve == kToneSrgb) return s <= 0.0031308f ? 12.92f * s : 1.055f * pow(s, 1.0f / 2.4f) - 0.055f;
    return s;
}

// The highlight knee of video cameras (the "knee" or "highlight compression"
// of broadcast and medical video processors): output levels above k bend
// into k + (1 - k) tanh((v - k) / (1 - k)), continuous in value and slope at
// k, so the sensor's saturation (v = 1) shows at k + 0.76 (1 - k), below
// white, and specular highlights keep their shape instead of clipping flat.
// k = 1: no knee.
float kneeCurve(float v, float k) {
    if (k >= 1.0f || v <= k) return v;
    return k + (1.0f - k) * tanh((v - k) / (1.0f - k));
}

// The inverse of kneeCurve for v < k + (1 - k) (round trips).
float inverseKneeCurve(float v, float k) {
    if (k >= 1.0f || v <= k) return v;
    float t = min((v - k) / (1.0f - k), 0.999999f);
    return k + (1.0f - k) * 0.5f * log((1.0f + t) / (1.0f - t));
}

// The inverse of toneCurve: display value -> sensor signal (round trips).
float inverseToneCurve(float v, int curve) {
    if (curve == kToneBt709) return v < 0.081f ? v / 4.5f : pow((v + 0.099f) / 1.099f, 1.0f / 0.45f);
    if (curve == kToneSrgb) return v <= 0.04045f ? v / 12.92f : pow((v + 0.055f) / 1.055f, 2.4f);
    return v;
}

// The sRGB decoding of an 8-bit texture's value (IEC 61966-2-1): the subject
// texture is stored as sRGB-encoded albedo, and shading needs it linear.
float srgbToLinear(float v) {
    return v <= 0.04045f ? v / 12.92f : pow((v + 0.055f) / 1.055f, 2.4f);
}
vec3 srgbToLinear3(vec3 v) {
    return vec3(srgbToLinear(v.x), srgbToLinear(v.y), srgbToLinear(v.z));
}

// Colour enhancement: v' = luma + g (v - luma), clamped (g = 1: unchanged;
// white and greys stay).
vec3 enhanceColour(vec3 v, float g) {
    float luma = 0.2126f * v.x + 0.7152f * v.y + 0.0722f * v.z;
    return clamp(vec3(luma) + (v - vec3(luma)) * g, 0.0f, 1.0f);
}

// Steps 1 (vignetting) to 5 for pixel (ix, iy) whose PSF-filtered radiance
// is `radiance`: the displayed value in [0, 1].
vec3 cameraPixel(vec3 radiance, int ix, int iy, Camera c) {
    float px = float(ix) + 0.5f;
    float py = float(iy) + 0.5f;
    vec3 s = (radiance * vignetting(px, py, c) + c.veil) * c.exposure;
    if (c.fullWell > 0.0f || c.readNoise > 0.0f) {
        vec3 g = pixelGaussians(ix, iy, c.frameSeed);
        s = vec3(sensorNoise(s.x, g.x, c), sensorNoise(s.y, g.y, c), sensorNoise(s.z, g.z, c));
    }
    s = clamp(s, 0.0f, 1.0f);
    vec3 v = vec3(kneeCurve(toneCurve(s.x, c.toneCurve), c.knee), kneeCurve(toneCurve(s.y, c.toneCurve), c.knee),
                  kneeCurve(toneCurve(s.z, c.toneCurve), c.knee));
    v = enhanceColour(v, c.saturation);
    return v * fovMask(px, py, c);
}
