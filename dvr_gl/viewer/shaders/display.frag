#version 330 core
// dvr view: the rendered image (linear, background composited, row 0 at the top) on the
// window's render area, encoded to sRGB as the screenshot's PNG is (IEC 61966-2-1).
in vec2 uv;
out vec4 frag_color;

uniform sampler2D u_image;

vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

void main() {
    vec4 rgba = texture(u_image, vec2(uv.x, 1.0 - uv.y));
    frag_color = vec4(linear_to_srgb(rgba.rgb), 1.0);
}
