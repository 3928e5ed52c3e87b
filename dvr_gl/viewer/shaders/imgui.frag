#version 330 core
// Dear ImGui: vertex colour times the font atlas (or another texture).
uniform sampler2D u_texture;
in vec2 uv;
in vec4 color;
out vec4 frag_color;

void main() {
    frag_color = color * texture(u_texture, uv);
}
