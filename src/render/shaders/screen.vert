#version 450 core
// One triangle covering the whole target (vertices 0-2, no vertex buffer): a full-screen pass.
void main() {
  const vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
