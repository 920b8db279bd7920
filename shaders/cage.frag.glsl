#version 450 core

uniform vec3 base_color;

out vec4 fragment_color;

void main() { fragment_color = vec4(base_color, 1.0); }
