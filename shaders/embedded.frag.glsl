#version 450 core
// Clips each (triangle, tet) instance to its tet: a fragment whose interpolated
// barycentric coordinates leave [0, 1] belongs to a neighbouring tet's instance.

in vec4 v_barycentric;
in vec3 v_normal;
in vec3 v_position;

uniform vec3 base_color;

out vec4 fragment_color;

vec3 shade(vec3 normal, vec3 position, vec3 color);  // lighting.frag.glsl

// The slack: the corners' barycentrics are exact in float to ~6e-8, and perspective-
// correct interpolation adds a few ulps more, so a fragment on a shared tet face reads
// |b| ≲ 1e-6 from both sides. Keeping fragments down to -1e-5 covers that band from both
// tets (no crack); the band is drawn twice at the same depth and colour, which an opaque
// pass cannot show.
const float kSlack = 1e-5;

void main() {
  vec4 b = v_barycentric;
  if (min(min(b.x, b.y), min(b.z, b.w)) < -kSlack) discard;
  fragment_color = vec4(shade(v_normal, v_position, base_color), 1.0);
}
