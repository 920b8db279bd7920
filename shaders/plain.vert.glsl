#version 450 core
// Plain meshes: obstacles, projectiles, and the original mesh in tests (the ground has
// its own shaders: ground.vert.glsl).

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;

uniform mat4 view_projection;
uniform mat4 model;

out vec3 v_normal;
out vec3 v_position;

void main() {
  vec4 world = model * vec4(position, 1.0);
  v_normal = transpose(inverse(mat3(model))) * normal;
  v_position = world.xyz;
  gl_Position = view_projection * world;
}
