#version 450 core
// Walls (thesis V.B): the tet faces fracture opened, drawn from the current nodes. One
// triangle per listed face slot 4t + k; its corners are the face's nodes in outward
// order (common/tet_mesh.h), so the face normal points out of the tet.

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };  // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };         // 4 per tet
layout(std430, binding = 3) readonly buffer Walls { uint wall_slot[]; };       // the faces to draw
layout(std430, binding = 4) readonly buffer FaceTiles { int face_tile[]; };    // per slot
layout(std430, binding = 5) readonly buffer FaceUvs { float face_uv[]; };      // 6 per slot

uniform mat4 view_projection;

out vec2 v_uv;
flat out int v_tile;
flat out vec3 v_normal;
out vec3 v_position;

const uint kFaceNodes[12] = uint[12](1u, 2u, 3u, 0u, 3u, 2u, 0u, 1u, 3u, 0u, 2u, 1u);

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

vec3 corner(uint slot, uint j) { return node(tet_node[4u * (slot / 4u) + kFaceNodes[3u * (slot % 4u) + j]]); }

void main() {
  uint slot = wall_slot[uint(gl_VertexID) / 3u], j = uint(gl_VertexID) % 3u;
  vec3 a = corner(slot, 0u), b = corner(slot, 1u), c = corner(slot, 2u);
  v_normal = cross(b - a, c - a);
  v_position = j == 0u ? a : (j == 1u ? b : c);
  v_uv = vec2(face_uv[6u * slot + 2u * j], face_uv[6u * slot + 2u * j + 1u]);
  v_tile = face_tile[slot];
  gl_Position = view_projection * vec4(v_position, 1.0);
}
