#version 330 core
// Ray bounds (dvr_gl.renderers.raycast.ray_bounds): a face of the non-empty blocks' union, projected
// by dvr_gl.gl.geometry's matrices (a point lands on the pixel whose ray passes through it).
in vec3 in_position;   // world
in vec2 in_plane;      // (axis: 0, 1, 2 for x, y, z; the plane's world coordinate)
flat out int v_axis;
flat out float v_plane;
uniform mat4 u_view_projection;

void main() {
    gl_Position = u_view_projection * vec4(in_position, 1.0);
    v_axis = int(in_plane.x + 0.5);
    v_plane = in_plane.y;
}
