#version 450 core
// Tessellated walls (thesis V.C): a face inside the solid that has relief is split the
// finer the more of the screen it covers (fractional levels, so detail grows smoothly as
// the camera nears), capped at max_level; faces without relief (crossing faces, or none
// allowed) stay one triangle and cost what the untessellated walls do.

layout(vertices = 3) out;

in vec2 v_uv[];
in vec2 v_detail_uv[];
flat in int v_tile[];
flat in vec3 v_normal[];
flat in vec3 v_tangent[];
flat in vec3 v_bitangent[];
in vec3 v_position[];
flat in float v_relief[];

out vec2 tc_uv[];
out vec2 tc_detail_uv[];
out vec3 tc_position[];
patch out int tc_tile;
patch out vec3 tc_normal;
patch out vec3 tc_tangent;
patch out vec3 tc_bitangent;
patch out float tc_relief;
patch out float tc_detail_lod;  // the detail map's mip level that one segment spans

uniform float max_level;          // ≥ 1
uniform vec2 viewport;            // [pixels]
uniform float pixels_per_segment; // the on-screen length one segment aims for
uniform int detail_resolution;    // texels per side of the detail map

/// An edge's on-screen length in pixels; the cap where it crosses the eye's plane (its
/// length on screen is unbounded there).
float screen_length(vec4 a, vec4 b) {
  if (a.w <= 0.0 || b.w <= 0.0) return max_level * pixels_per_segment;
  return length((a.xy / a.w - b.xy / b.w) * 0.5 * viewport);
}

void main() {
  tc_uv[gl_InvocationID] = v_uv[gl_InvocationID];
  tc_detail_uv[gl_InvocationID] = v_detail_uv[gl_InvocationID];
  tc_position[gl_InvocationID] = v_position[gl_InvocationID];
  gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
  if (gl_InvocationID != 0) return;
  tc_tile = v_tile[0];
  tc_normal = v_normal[0];
  tc_tangent = v_tangent[0];
  tc_bitangent = v_bitangent[0];
  tc_relief = v_relief[0];
  // The outer levels stay 1: relief fades to nothing at the edges, so splitting them
  // adds nothing, and a split edge beside an unsplit neighbour (a crossing face, drawn
  // flat) would leave T-junctions that rounding can open into pinholes. The inner level
  // follows the longest edge on screen.
  gl_TessLevelOuter[0] = 1.0;
  gl_TessLevelOuter[1] = 1.0;
  gl_TessLevelOuter[2] = 1.0;
  float inner = 1.0;
  if (v_relief[0] > 0.0) {
    float longest = max(screen_length(gl_in[0].gl_Position, gl_in[1].gl_Position),
                        max(screen_length(gl_in[1].gl_Position, gl_in[2].gl_Position),
                            screen_length(gl_in[2].gl_Position, gl_in[0].gl_Position)));
    inner = clamp(longest / pixels_per_segment, 1.0, max_level);
  }
  gl_TessLevelInner[0] = inner;
  // Sample the height no finer than the mesh can show: a segment spans this many
  // texels of the detail map, so its mip level is their log2 (no aliasing or popping).
  vec2 span = abs(v_detail_uv[1] - v_detail_uv[0]) + abs(v_detail_uv[2] - v_detail_uv[0]);
  tc_detail_lod = max(0.0, log2(max(span.x, span.y) * float(detail_resolution) / inner));
}
