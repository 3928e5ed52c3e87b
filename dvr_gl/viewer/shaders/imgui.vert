#version 330 core
// Dear ImGui's vertices: positions in window pixels (y down), texture coordinates, sRGB colour.
uniform vec2 u_display_size;
in vec2 in_position;
in vec2 in_uv;
in vec4 in_color;
out vec2 uv;
out vec4 color;

void main() {
    uv = in_uv;
    color = in_color;
    gl_Position = vec4(in_position / u_display_size * vec2(2.0, -2.0) + vec2(-1.0, 1.0), 0.0, 1.0);
}
