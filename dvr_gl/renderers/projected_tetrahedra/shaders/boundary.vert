#version 430
// The mesh's boundary faces, to count how many of them each pixel's ray crosses
// (dvr_gl/renderers/projected_tetrahedra: which rays the exact order must cast).
layout(location = 0) in vec3 in_position;  // centre-relative
uniform mat4 u_view_projection;

void main() {
    gl_Position = u_view_projection * vec4(in_position, 1.0);
}
