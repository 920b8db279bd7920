#version 450 core
// The ground: one square of its plane (a triangle strip of four corners) around the
// point under the camera's target, as far as the view reaches.

uniform mat4 view_projection;
uniform vec3 centre;  // on the plane
uniform vec3 axis_u;  // unit, in the plane
uniform vec3 axis_v;  // unit, in the plane, normal = u × v
uniform float half_size;
uniform mat4 shadow_matrix;  // world → shadow map [0, 1]³ (orthographic: affine, so it interpolates exactly)

out vec3 v_position;
out vec3 v_shadow;

void main() {
  vec2 corner = vec2((gl_VertexID & 1) == 0 ? -1.0 : 1.0, (gl_VertexID & 2) == 0 ? -1.0 : 1.0);
  v_position = centre + half_size * (corner.x * axis_u + corner.y * axis_v);
  v_shadow = (shadow_matrix * vec4(v_position, 1.0)).xyz;
  gl_Position = view_projection * vec4(v_position, 1.0);
}
