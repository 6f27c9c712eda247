// camera_mask.frag: the scope's field stop as an occluder. Drawn into the HDR
// target's depth buffer before the surface pass, at the near plane, over the
// pixels outside the mask (grown by kMaskMarginPx so the PSF's neighbours of
// every visible pixel are still shaded); the surface's fragments there then
// fail the depth test before they are shaded. No colour is written. The
// renderer prepends "#version 330 core" and camera.glsl.
uniform Camera uCamera;

out vec4 fragColor;

void main() {
    Camera c = uCamera;
    c.maskRadius = uCamera.maskRadius + kMaskMarginPx / (0.5 * min(uCamera.width, uCamera.height));
    if (fovMask(gl_FragCoord.x, gl_FragCoord.y, c) > 0.0) discard;
    fragColor = vec4(0.0);
}
