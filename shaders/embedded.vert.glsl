#version 450 core
// The embedded render mesh (thesis V.A): each corner of a (triangle, tet) instance is
// placed from its tet's current nodes by its barycentric coordinates.

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };    // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };           // 4 per tet
layout(std430, binding = 2) readonly buffer RestInverse { float rest_inverse[]; };  // 9 per tet: Du⁻¹, column-major
layout(std430, binding = 7) readonly buffer Fragments { uint fragment[]; };          // per tet

layout(location = 0) in vec4 barycentric;
layout(location = 1) in uint tet;
layout(location = 2) in vec3 rest_normal;

uniform mat4 view_projection;
uniform bool fragment_colors;

out vec4 v_barycentric;
flat out uint v_fragment;
out vec3 v_normal;
out vec3 v_position;

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

vec3 column(uint first) { return vec3(rest_inverse[first], rest_inverse[first + 1u], rest_inverse[first + 2u]); }

void main() {
  vec3 x[4];
  vec3 p = vec3(0.0);
  for (uint i = 0u; i < 4u; ++i) {
    x[i] = node(tet_node[4u * tet + i]);
    p += barycentric[i] * x[i];
  }
  // The tet's deformation gradient F = Dx Du⁻¹ from its current edges, so only node
  // positions go to the GPU each frame. Normals transform with F's cofactor (det F F⁻ᵀ):
  // its columns are the cross products of F's. Exact for the tet's affine map, and
  // defined even when F is singular.
  mat3 F = mat3(x[1] - x[0], x[2] - x[0], x[3] - x[0]) * mat3(column(9u * tet), column(9u * tet + 3u), column(9u * tet + 6u));
  v_normal = mat3(cross(F[1], F[2]), cross(F[2], F[0]), cross(F[0], F[1])) * rest_normal;
  v_barycentric = barycentric;
  v_fragment = fragment_colors ? fragment[tet] : 0u;
  v_position = p;
  gl_Position = view_projection * vec4(p, 1.0);
}
