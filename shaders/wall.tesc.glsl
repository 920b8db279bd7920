#version 450 core
// Tessellated walls (thesis V.C): a face inside the solid that has relief is split the
// finer the more of the screen its edges cover (fractional levels, so detail grows
// smoothly as the camera nears), capped at max_level; faces without relief (crossing
// faces, or none allowed) stay one triangle and cost what the untessellated walls do.

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

/// An edge's level from its on-screen length. An edge crossing the eye's plane gets
/// the cap: its length on screen is unbounded. Symmetric in (a, b), so the two patches
/// that share an edge split it alike.
float edge_level(vec4 a, vec4 b) {
  if (a.w <= 0.0 || b.w <= 0.0) return max_level;
  vec2 on_screen = (a.xy / a.w - b.xy / b.w) * 0.5 * viewport;
  return clamp(length(on_screen) / pixels_per_segment, 1.0, max_level);
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
  // Outer level i is the edge facing corner i (the one where gl_TessCoord[i] = 0).
  vec3 outer = vec3(1.0);
  if (v_relief[0] > 0.0) {
    outer = vec3(edge_level(gl_in[1].gl_Position, gl_in[2].gl_Position),
                 edge_level(gl_in[2].gl_Position, gl_in[0].gl_Position),
                 edge_level(gl_in[0].gl_Position, gl_in[1].gl_Position));
  }
  gl_TessLevelOuter[0] = outer.x;
  gl_TessLevelOuter[1] = outer.y;
  gl_TessLevelOuter[2] = outer.z;
  float inner = max(outer.x, max(outer.y, outer.z));
  gl_TessLevelInner[0] = inner;
  // Sample the height no finer than the mesh can show: a segment spans this many
  // texels of the detail map, so its mip level is their log2 (no aliasing or popping).
  vec2 span = abs(v_detail_uv[1] - v_detail_uv[0]) + abs(v_detail_uv[2] - v_detail_uv[0]);
  tc_detail_lod = max(0.0, log2(max(span.x, span.y) * float(detail_resolution) / inner));
}
