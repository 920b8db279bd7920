#version 450 core
// Tessellated walls (thesis V.C): each generated vertex is placed on the face and moved
// along the face's normal by the detail height, scaled by the face's relief: at most
// the bake's clearance (walls/face_clearance), the distance below the outer surface
// every point of the face keeps, so the interior never pokes through the outside,
// which the thesis wanted and could not bound (the bound is the rest shape's: a tet
// squashed hard near the surface can bring the outside closer than it). The relief
// fades to nothing at the face's edges, which stay unsplit (wall.tesc.glsl): walls
// meeting there (other tets' faces, crossing faces drawn flat) share their edges
// exactly, so no crack opens between them at any level.

layout(triangles, fractional_odd_spacing, ccw) in;

in vec2 tc_uv[];
in vec2 tc_detail_uv[];
in vec3 tc_position[];
patch in int tc_tile;
patch in vec3 tc_normal;
patch in vec3 tc_tangent;
patch in vec3 tc_bitangent;
patch in float tc_relief;
patch in float tc_detail_lod;

out vec2 v_uv;
out vec2 v_detail_uv;
flat out int v_tile;
flat out vec3 v_normal;
flat out vec3 v_tangent;
flat out vec3 v_bitangent;
out vec3 v_position;

uniform mat4 view_projection;
uniform sampler2D detail_height;  // 0.5 = the face's plane

/// Barycentric distance from the edges over which the relief fades in.
const float kEdgeFade = 0.2;

void main() {
  vec3 w = gl_TessCoord;
  v_uv = w.x * tc_uv[0] + w.y * tc_uv[1] + w.z * tc_uv[2];
  v_detail_uv = w.x * tc_detail_uv[0] + w.y * tc_detail_uv[1] + w.z * tc_detail_uv[2];
  vec3 position = w.x * tc_position[0] + w.y * tc_position[1] + w.z * tc_position[2];
  if (tc_relief > 0.0) {
    // Along the bake's face orientation (its u × v axes), not the tet's outward normal:
    // the two tets that share a face then raise the same surface, so the two sides of a
    // crack interlock as one fracture surface instead of mirroring each other.
    vec3 up = normalize(cross(tc_tangent, tc_bitangent));
    float height = textureLod(detail_height, v_detail_uv, tc_detail_lod).r * 2.0 - 1.0;
    float fade = smoothstep(0.0, kEdgeFade, min(w.x, min(w.y, w.z)));
    position += up * (height * tc_relief * fade);
  }
  v_position = position;
  v_tile = tc_tile;
  v_normal = tc_normal;
  v_tangent = tc_tangent;
  v_bitangent = tc_bitangent;
  gl_Position = view_projection * vec4(position, 1.0);
}
