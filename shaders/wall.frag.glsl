#version 450 core
// A wall shows the solid's part of its face: a crossing face tests the bake's signed
// distance to the exact contour, filtered linearly, so the edge is crisp at any zoom
// (the thesis sampled a mask by nearest texel); a face inside the solid is drawn whole.

in vec2 v_uv;
flat in int v_tile;
flat in vec3 v_normal;
in vec3 v_position;

uniform sampler2DArray tiles;
uniform vec3 base_color;

out vec4 fragment_color;

vec3 shade(vec3 normal, vec3 position, vec3 color);  // lighting.frag.glsl

void main() {
  // 128 of 255 and above is inside (formats/bundle.h): the boundary sits at 127.5 / 255.
  if (v_tile >= 0 && texture(tiles, vec3(v_uv, float(v_tile))).r < 127.5 / 255.0) discard;
  fragment_color = vec4(shade(v_normal, v_position, base_color), 1.0);
}
