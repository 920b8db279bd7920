#version 450 core
// A wall shows the solid's part of its face: a crossing face tests the bake's signed
// distance to the exact contour, filtered linearly, so the edge is crisp at any zoom
// (the thesis sampled a mask by nearest texel); a face inside the solid is drawn whole.

in vec2 v_uv;
in vec2 v_detail_uv;
flat in int v_tile;
flat in vec3 v_normal;
flat in vec3 v_tangent;
flat in vec3 v_bitangent;
in vec3 v_position;

uniform sampler2DArray tiles;
uniform sampler2D detail_normal;  // tangent-space, 0.5 = 0
uniform bool normal_mapping;
uniform ivec2 tile_layout;  // texels per tile side, tiles per layer side (the renderer's TileAtlas)
uniform vec3 base_color;
uniform float solid_threshold;  // the least filtered distance drawn (renderer.cpp: kWallErosionTexels)

out vec4 fragment_color;

vec3 shade(vec3 normal, vec3 position, vec3 color);  // lighting.frag.glsl

/// The tile's signed distance at (u, v), filtered linearly between texel centres and
/// clamped to the tile's own texels (the bake extends each field past its face's edges).
float signed_distance(int tile, vec2 uv) {
  int res = tile_layout.x, cells = tile_layout.y;
  int cell = tile % (cells * cells), layer = tile / (cells * cells);
  vec2 texel = clamp(uv * float(res), vec2(0.5), vec2(float(res) - 0.5));
  vec2 origin = vec2(float(cell % cells), float(cell / cells)) * float(res);
  return texture(tiles, vec3((origin + texel) / float(res * cells), float(layer))).r;
}

void main() {
  // 128 of 255 and above is inside (formats/bundle.h): the boundary sits at 127.5 / 255;
  // the threshold keeps the wall a little inside it, where filtering cannot carry it
  // past the surface it meets.
  if (v_tile >= 0 && signed_distance(v_tile, v_uv) < solid_threshold) discard;
  vec3 normal = normalize(v_normal);
  if (normal_mapping) {
    // The detail's slope along u and v tilts the face normal (its tangent frame from the
    // tile's axes), so the interior catches light as a rough solid, not a flat cut.
    vec3 detail = texture(detail_normal, v_detail_uv).xyz * 2.0 - 1.0;
    vec3 t = normalize(v_tangent - dot(v_tangent, normal) * normal);
    vec3 b = cross(normal, t) * sign(dot(cross(normal, t), v_bitangent));
    normal = normalize(detail.x * t + detail.y * b + detail.z * normal);
  }
  fragment_color = vec4(shade(normal, v_position, base_color), 1.0);
}
