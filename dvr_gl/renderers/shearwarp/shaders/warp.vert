#version 330 core
// Shear-warp's final warp: the intermediate image on a quad transformed by M_warp.
// position: intermediate-image coordinates (pixel centres at integers).
// u_warp: (u, v, 1) -> homogeneous NDC (x w, y w, w); w = 1 for parallel projection, so the
// quad is then affine, and GL interpolates the texture coordinate perspective-correctly otherwise.
uniform mat3 u_warp;
uniform vec2 u_size;        // intermediate image (width, height) in pixels
in vec2 position;
out vec2 texcoord;

void main() {
    vec3 h = u_warp * vec3(position, 1.0);
    gl_Position = vec4(h.xy, 0.0, h.z);
    texcoord = (position + 0.5) / u_size;
}
