#version 450 core
// Clips each (triangle, tet) instance to its tet: a fragment whose interpolated
// barycentric coordinates leave [0, 1] belongs to a neighbouring tet's instance.

in vec4 v_barycentric;
in vec3 v_normal;
in vec3 v_position;
flat in uint v_fragment;

layout(std430, binding = 10) readonly buffer Replicas { uint replicas[]; };  // per instance

uniform vec3 base_color;
uniform bool fragment_colors;
uniform bool replication_colors;
uniform vec3 replication_palette[5];  // renderer.h: replication_color()

out vec4 fragment_color;

vec3 shade(vec3 normal, vec3 position, vec3 color);  // lighting.frag.glsl

// The slack: the corners' barycentrics are exact in float to ~6e-8, and perspective-
// correct interpolation adds a few ulps more, so a fragment on a shared tet face reads
// |b| ≲ 1e-6 from both sides. Keeping fragments down to -1e-5 covers that band from both
// tets (no crack); the band is drawn twice at the same depth and colour, which an opaque
// pass cannot show.
const float kSlack = 1e-5;
// The reach: each instance is also kept half a pixel past its tet (the barycentrics'
// change over a pixel, fwidth), so a crack narrower than about a pixel is drawn closed.
// Node splitting opens a face by the split node's drift, micrometres at first, and the
// walls behind such a crack showed through it as isolated specks (issue 44: 49-130 a
// frame in the sample before any piece came off; none with this). Where no crack is,
// the extra half pixel lies under the neighbour tet's own instance (decisions/0050).
const float kReachPixels = 0.5;

void main() {
  vec4 b = v_barycentric;
  vec4 reach = max(vec4(kSlack), kReachPixels * fwidth(b));
  if (any(lessThan(b, -reach))) discard;
  vec3 color = base_color;
  if (fragment_colors) {
    // A colour per fragment id, spread around the hue circle by the golden ratio.
    float hue = fract(0.61803399 * float(v_fragment) + 0.1);
    color = clamp(abs(fract(hue + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0) * 0.7 + 0.2;
  }
  // Thesis Fig. 24: each triangle by how many tets it is drawn in. The draw's
  // primitives are the instances, in order.
  if (replication_colors) color = replication_palette[clamp(replicas[gl_PrimitiveID], 1u, 5u) - 1u];
  fragment_color = vec4(shade(v_normal, v_position, color), 1.0);
}
