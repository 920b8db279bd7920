#version 450 core
// The sky behind everything: the horizon's colour at and below the horizon, turning to
// the zenith's above it, by each pixel's view ray (so it stays level as the camera
// tilts). The ground fades into the same horizon colour (ground.frag.glsl).

in vec4 v_near;
in vec4 v_far;

uniform vec3 up;  // unit, the world's
uniform vec3 horizon;
uniform vec3 zenith;

out vec4 fragment_color;

void main() {
  vec3 ray = normalize(v_far.xyz / v_far.w - v_near.xyz / v_near.w);
  float elevation = max(dot(ray, up), 0.0);
  fragment_color = vec4(mix(horizon, zenith, smoothstep(0.0, 0.7, elevation)), 1.0);
}
