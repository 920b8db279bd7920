#version 450 core
// Debug view: a body's collision spheres, one instance of a unit sphere each, its centre
// placed from its tet's current nodes by its barycentric coordinates (as the physics
// places it), its radius the physics' own.

layout(std430, binding = 0) readonly buffer Nodes { float node_position[]; };  // 3 per node
layout(std430, binding = 1) readonly buffer Tets { uint tet_node[]; };         // 4 per tet
struct Sphere {
  vec4 barycentric;
  uint tet;
  float radius;
};
layout(std430, binding = 9) readonly buffer Spheres { Sphere sphere[]; };

layout(location = 0) in vec3 position;  // on the unit sphere
layout(location = 1) in vec3 normal;

uniform mat4 view_projection;

out vec3 v_normal;
out vec3 v_position;

vec3 node(uint n) { return vec3(node_position[3u * n], node_position[3u * n + 1u], node_position[3u * n + 2u]); }

void main() {
  Sphere s = sphere[gl_InstanceID];
  vec3 centre = vec3(0.0);
  for (uint i = 0u; i < 4u; ++i) centre += s.barycentric[i] * node(tet_node[4u * s.tet + i]);
  v_position = centre + s.radius * position;
  v_normal = normal;
  gl_Position = view_projection * vec4(v_position, 1.0);
}
