#version 450 core
// One directional light, Lambert diffuse plus a Blinn-Phong highlight; normals are
// turned towards the eye, so a face seen from behind (an open scan's inside, an
// inverted tet) is lit rather than black. Turned by reflection in the plane across the
// view ray, not negated: a smooth normal that leans just past the contour (either side
// of a silhouette) stays almost as it is, where negating it lit the contour's pixels as
// if facing away from the light (dark specks along every silhouette; issue 44).

uniform vec3 eye;
uniform vec3 light_towards;  // unit, from the scene to the light
uniform float ambient;

vec3 shade(vec3 normal, vec3 position, vec3 color) {
  vec3 to_eye = normalize(eye - position);
  vec3 n = normalize(normal);
  n -= 2.0 * min(dot(n, to_eye), 0.0) * to_eye;
  float diffuse = max(dot(n, light_towards), 0.0);
  vec3 half_way = normalize(light_towards + to_eye);
  float specular = pow(max(dot(n, half_way), 0.0), 48.0) * 0.25;
  return color * (ambient + (1.0 - ambient) * diffuse) + vec3(specular);
}
