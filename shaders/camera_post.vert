// camera_post.vert: one triangle that covers the frame (no vertex buffer:
// positions from gl_VertexID), for the camera's post pass and the mask pass.
void main() {
    float x = float((gl_VertexID & 1) * 4 - 1);
    float y = float((gl_VertexID >> 1) * 4 - 1);
    gl_Position = vec4(x, y, -1.0, 1.0);  // at the near plane: the mask pass's occluder
}
