#version 450 core
// The shadow map's embedded casters: each corner placed from its tet's current nodes by
// its barycentric coordinates, as embedded.vert.glsl places it, without the normal (a
// depth pass needs none, and llvmpipe pays for every vertex twice a frame).

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };  // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };         // 4 per tet

layout(location = 0) in vec4 barycentric;
layout(location = 1) in uint tet;

uniform mat4 view_projection;

out vec4 v_barycentric;

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

void main() {
  vec3 p = vec3(0.0);
  for (uint i = 0u; i < 4u; ++i) p += barycentric[i] * node(tet_node[4u * tet + i]);
  v_barycentric = barycentric;
  gl_Position = view_projection * vec4(p, 1.0);
}
