#version 450 core
// The shadow map's plain casters (projectiles, obstacles): depth only.

void main() {}
