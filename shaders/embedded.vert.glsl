#version 450 core
// The embedded render mesh (thesis V.A): each corner of a (triangle, tet) instance is
// placed from its tet's current nodes by its barycentric coordinates.

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };    // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };           // 4 per tet
layout(std430, binding = 2) readonly buffer Deformation { float deformation[]; };  // 9 per tet, column-major F

layout(location = 0) in vec4 barycentric;
layout(location = 1) in uint tet;
layout(location = 2) in vec3 rest_normal;

uniform mat4 view_projection;

out vec4 v_barycentric;
out vec3 v_normal;
out vec3 v_position;

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

vec3 column(uint first) { return vec3(deformation[first], deformation[first + 1u], deformation[first + 2u]); }

void main() {
  vec3 p = vec3(0.0);
  for (uint i = 0u; i < 4u; ++i) p += barycentric[i] * node(tet_node[4u * tet + i]);
  // Normals transform with the cofactor of F (det F · F⁻ᵀ): its columns are the cross
  // products of F's. Exact for the tet's affine map, and defined even when F is singular.
  vec3 a = column(9u * tet), b = column(9u * tet + 3u), c = column(9u * tet + 6u);
  v_normal = mat3(cross(b, c), cross(c, a), cross(a, b)) * rest_normal;
  v_barycentric = barycentric;
  v_position = p;
  gl_Position = view_projection * vec4(p, 1.0);
}
