#version 450 core

in vec3 v_normal;
in vec3 v_position;

uniform vec3 base_color;

out vec4 fragment_color;

vec3 shade(vec3 normal, vec3 position, vec3 color);  // lighting.frag.glsl

void main() { fragment_color = vec4(shade(v_normal, v_position, base_color), 1.0); }
