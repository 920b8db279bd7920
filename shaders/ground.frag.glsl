#version 450 core
// The ground reads as ground: a faint checker in world units (so its cells give scale
// and motion), filtered over each pixel's footprint so it never shimmers, lit by the
// scene's light, darkened where the shadow map says a body or a projectile blocks the
// light, and faded with distance into the sky's horizon colour.

in vec3 v_position;

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
uniform mat4 shadow_matrix;  // world → shadow map [0, 1]³
uniform sampler2DShadow shadow_map;

out vec4 fragment_color;

/// The checker's mean over the pixel's footprint: 0 or 1 in a cell, ½ where cells
/// are smaller than a pixel (the box-filtered checker).
float checker(vec2 p) {
  vec2 w = max(fwidth(p), vec2(1e-4));
  vec2 i = 2.0 * (abs(fract((p - 0.5 * w) * 0.5) - 0.5) - abs(fract((p + 0.5 * w) * 0.5) - 0.5)) / w;
  return 0.5 - 0.5 * i.x * i.y;
}

/// How much of the light reaches the point: 4 filtered comparisons half a texel apart
/// (16 texels in all), so the shadow's edge is soft rather than stepped.
float light_reaching(vec3 position) {
  vec4 s = shadow_matrix * vec4(position, 1.0);
  vec3 p = s.xyz / s.w;
  if (any(lessThan(p.xy, vec2(0.0))) || any(greaterThan(p.xy, vec2(1.0)))) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int k = 0; k < 4; ++k) {
    vec2 offset = vec2((k & 1) == 0 ? -0.75 : 0.75, (k & 2) == 0 ? -0.75 : 0.75) * texel;
    lit += texture(shadow_map, vec3(p.xy + offset, min(p.z, 1.0)));
  }
  return 0.25 * lit;
}

void main() {
  vec2 p = vec2(dot(v_position, axis_u), dot(v_position, axis_v)) / cell;
  float tone = 1.0 + 0.06 * (checker(p) - 0.5);
  // A shadow keeps a third of the direct light: the sky fills it in, so it reads as
  // shade on the ground, not a hole in it.
  float lit = shadows ? mix(0.35, 1.0, light_reaching(v_position)) : 1.0;
  float diffuse = max(dot(normal, light_towards), 0.0) * lit;
  vec3 color = base_color * tone * (ambient + (1.0 - ambient) * diffuse);
  float fade = smoothstep(fog.x, fog.y, length(v_position - eye));
  fragment_color = vec4(mix(color, horizon, fade), 1.0);
}
