#version 450 core
// The shadow map's embedded casters: depth only, each instance clipped to its tet as
// embedded.frag.glsl clips it (so a fragment flying off casts its own shadow, not its
// neighbours' instances').

in vec4 v_barycentric;

void main() {
  vec4 b = v_barycentric;
  if (any(lessThan(b, -max(vec4(1e-5), 0.5 * fwidth(b))))) discard;
}
