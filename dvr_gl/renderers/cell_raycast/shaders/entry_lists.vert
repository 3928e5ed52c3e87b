#version 430
// The mesh's boundary faces, each vertex with its face's cell and outward normal: grown by
// entry_lists.geom and drawn into the per-pixel lists of the faces where rays enter the mesh
// (entry_lists.frag).
layout(location = 0) in vec3 in_position;  // centre-relative
layout(location = 1) in uint in_cell;
layout(location = 2) in vec3 in_normal;    // out of the cell
uniform mat4 u_view_projection;
flat out uint v_cell;
flat out vec3 v_normal;
out vec3 v_position;

void main() {
    v_cell = in_cell;
    v_normal = in_normal;
    v_position = in_position;
    gl_Position = u_view_projection * vec4(in_position, 1.0);
}
