#version 450 core
// Debug view: the cage's edges, six per tet, from the current nodes (after splits).

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };  // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };         // 4 per tet

uniform mat4 view_projection;

const uint kEdgeEnds[12] = uint[12](0u, 1u, 0u, 2u, 0u, 3u, 1u, 2u, 1u, 3u, 2u, 3u);

void main() {
  uint edge = uint(gl_VertexID) / 2u, end = uint(gl_VertexID) % 2u;
  uint n = tet_node[4u * (edge / 6u) + kEdgeEnds[2u * (edge % 6u) + end]];
  gl_Position = view_projection * vec4(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u], 1.0);
}
