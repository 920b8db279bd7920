#version 450 core
// The sky: one triangle that covers the screen at the far plane, drawn last with the
// depth test, so only pixels nothing else covered pay for it. Each corner carries its
// view ray's near and far points (homogeneous, so they interpolate exactly).

uniform mat4 inverse_view_projection;

out vec4 v_near;
out vec4 v_far;

void main() {
  vec2 ndc = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  v_near = inverse_view_projection * vec4(ndc, -1.0, 1.0);
  v_far = inverse_view_projection * vec4(ndc, 1.0, 1.0);
  gl_Position = vec4(ndc, 1.0, 1.0);
}
