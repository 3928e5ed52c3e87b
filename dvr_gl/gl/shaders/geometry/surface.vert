#version 330 core
// Opaque meshes (dvr_gl.geometry): triangles in world space, each vertex with its face's normal and
// the mesh's colour (not interpolated: flat).
in vec3 position;
in vec3 normal;
in vec3 colour;
uniform mat4 u_view_projection;
out vec3 world;
flat out vec3 face_normal;
flat out vec3 face_colour;

void main() {
    world = position;
    face_normal = normal;
    face_colour = colour;
    gl_Position = u_view_projection * vec4(position, 1.0);
}
