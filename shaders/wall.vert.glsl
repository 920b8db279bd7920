#version 450 core
// Walls (thesis V.B): the tet faces fracture opened, drawn from the current nodes. One
// triangle per listed face slot 4t + k; its corners are the face's nodes in outward
// order (common/tet_mesh.h), so the face normal points out of the tet.

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };  // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };         // 4 per tet
layout(std430, binding = 3) readonly buffer Walls { uint wall_slot[]; };       // the faces to draw
layout(std430, binding = 4) readonly buffer FaceTiles { int face_tile[]; };    // per slot
layout(std430, binding = 5) readonly buffer FaceUvs { float face_uv[]; };      // 6 per slot
layout(std430, binding = 6) readonly buffer DetailRepeat { float detail_repeat[]; };  // 2 per slot
layout(std430, binding = 8) readonly buffer FaceRelief { float face_relief[]; };       // per slot [m]

uniform mat4 view_projection;

out vec2 v_uv;
out vec2 v_detail_uv;
flat out int v_tile;
flat out vec3 v_normal;
flat out vec3 v_tangent;    // ∂position/∂u of the tile's parameters, for the detail normals
flat out vec3 v_bitangent;  // ∂position/∂v
out vec3 v_position;
flat out float v_relief;  // for the tessellation stages (wall.tesc.glsl): the most relief allowed

const uint kFaceNodes[12] = uint[12](1u, 2u, 3u, 0u, 3u, 2u, 0u, 1u, 3u, 0u, 2u, 1u);

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

vec3 corner(uint slot, uint j) { return node(tet_node[4u * (slot / 4u) + kFaceNodes[3u * (slot % 4u) + j]]); }

vec2 uv(uint slot, uint j) { return vec2(face_uv[6u * slot + 2u * j], face_uv[6u * slot + 2u * j + 1u]); }

void main() {
  uint slot = wall_slot[uint(gl_VertexID) / 3u], j = uint(gl_VertexID) % 3u;
  vec3 a = corner(slot, 0u), b = corner(slot, 1u), c = corner(slot, 2u);
  v_normal = cross(b - a, c - a);
  // The face's (u, v) axes in space: the corners' uv are a unit triangle's, in some order.
  vec2 d1 = uv(slot, 1u) - uv(slot, 0u), d2 = uv(slot, 2u) - uv(slot, 0u);
  float r = 1.0 / (d1.x * d2.y - d1.y * d2.x);
  v_tangent = ((b - a) * d2.y - (c - a) * d1.y) * r;
  v_bitangent = ((c - a) * d1.x - (b - a) * d2.x) * r;
  v_position = j == 0u ? a : (j == 1u ? b : c);
  v_uv = uv(slot, j);
  v_detail_uv = v_uv * vec2(detail_repeat[2u * slot], detail_repeat[2u * slot + 1u]);
  v_tile = face_tile[slot];
  v_relief = face_relief[slot];
  gl_Position = view_projection * vec4(v_position, 1.0);
}
