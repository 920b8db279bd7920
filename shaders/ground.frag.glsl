#version 450 core
// The ground reads as ground: a faint checker in world units (so its cells give scale
// and motion), filtered over each pixel's footprint so it never shimmers, lit by the
// scene's light, darkened where the shadow map says a body or a projectile blocks the
// light, and faded with distance into the sky's horizon colour.

in vec3 v_position;
in vec3 v_shadow;  // the point in the shadow map [0, 1]³

uniform vec3 axis_u;
uniform vec3 axis_v;
uniform vec3 normal;
uniform float cell;        // checker cell side [m]
uniform vec3 base_color;
uniform vec3 eye;
uniform vec3 light_towards;
uniform float ambient;
uniform vec3 horizon;
uniform vec2 fog;          // distances from the eye where the fade starts and ends
uniform bool shadows;
uniform sampler2DShadow shadow_map;

out vec4 fragment_color;

/// The checker's mean over the pixel's footprint: 0 or 1 in a cell, ½ where cells
/// are smaller than a pixel (the box-filtered checker).
float checker(vec2 p) {
  vec2 w = max(fwidth(p), vec2(1e-4));
  vec2 i = 2.0 * (abs(fract((p - 0.5 * w) * 0.5) - 0.5) - abs(fract((p + 0.5 * w) * 0.5) - 0.5)) / w;
  return 0.5 - 0.5 * i.x * i.y;
}

/// How much of the light reaches the point: one filtered comparison (2×2 texels, so the
/// shadow's edge is a texel soft). One, not more: llvmpipe runs the sampling for every
/// ground pixel, and four taps cost 20 ms a 1280×720 frame.
float light_reaching(vec3 p) { return texture(shadow_map, vec3(p.xy, min(p.z, 1.0))); }

void main() {
  vec2 p = vec2(dot(v_position, axis_u), dot(v_position, axis_v)) / cell;
  float tone = 1.0 + 0.06 * (checker(p) - 0.5);
  // A shadow keeps a third of the direct light: the sky fills it in, so it reads as
  // shade on the ground, not a hole in it.
  float lit = shadows ? mix(0.35, 1.0, light_reaching(v_shadow)) : 1.0;
  float diffuse = max(dot(normal, light_towards), 0.0) * lit;
  vec3 color = base_color * tone * (ambient + (1.0 - ambient) * diffuse);
  float fade = smoothstep(fog.x, fog.y, length(v_position - eye));
  fragment_color = vec4(mix(color, horizon, fade), 1.0);
}
