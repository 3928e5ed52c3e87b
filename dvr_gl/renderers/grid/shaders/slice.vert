#version 330 core
// Proxy geometry of the slicing renderers: slice polygons in world space.
in vec3 position;
uniform mat4 u_view_projection;
out vec3 world;

void main() {
    world = position;
    gl_Position = u_view_projection * vec4(position, 1.0);
}
