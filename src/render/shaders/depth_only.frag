#version 450 core
// Depth alone (the water's back faces): nothing to shade.
void main() {}
