// lens_remap.frag: the frame through a lens (Renderer::setLensRays). The
// surface pass drew the faces of a cube map around the camera (eye axes);
// each output pixel reads it along its own ray, with bilinear filtering
// (seamless across the faces). Pixels without a ray stay black. The
// renderer prepends "#version 330 core".
uniform samplerCube uFaces;  // linear radiance, or a debug mode's colour
uniform sampler2D uRays;     // per output pixel: the ray in eye axes (xyz) and 1, or 0 where none

out vec4 fragColor;

void main() {
    vec4 ray = texelFetch(uRays, ivec2(gl_FragCoord.xy), 0);
    fragColor = ray.w > 0.0 ? vec4(texture(uFaces, ray.xyz).rgb, 1.0) : vec4(0.0, 0.0, 0.0, 1.0);
}
