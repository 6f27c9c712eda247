// lens_remap.frag: the frame through a lens (Renderer::setLensRays). The
// surface pass drew either one wide perspective face along the camera's axis
// (uPlaneTan > 0: its half-width, tan of its half-angle) or the faces of a
// cube map around the camera (eye axes); each output pixel reads it along
// its own ray, with bilinear filtering (seamless across a cube's faces).
// Pixels without a ray stay black. The renderer prepends "#version 330 core".
uniform samplerCube uFaces;  // linear radiance, or a debug mode's colour
uniform sampler2D uPlane;    // the same, on the one wide face
uniform float uPlaneTan;     // > 0: read uPlane; 0: read uFaces
uniform sampler2D uRays;     // per output pixel: the ray in eye axes (xyz) and 1, or 0 where none

out vec4 fragColor;

void main() {
    vec4 ray = texelFetch(uRays, ivec2(gl_FragCoord.xy), 0);
    if (ray.w <= 0.0) {
        fragColor = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    if (uPlaneTan > 0.0) {
        // The eye looks down -z: the face's window coordinates of the ray.
        vec2 st = ray.xy / (-ray.z * uPlaneTan) * 0.5 + 0.5;
        fragColor = vec4(texture(uPlane, st).rgb, 1.0);
    } else {
        fragColor = vec4(texture(uFaces, ray.xyz).rgb, 1.0);
    }
}
