#version 330 core
// Bilinear lookup of the premultiplied intermediate image (its border is transparent).
// PYRAMID (a perspective eye inside the volume, one factorization per pyramid of rays): only the
// pixels whose ray's principal axis and direction along it are this pyramid's, by the rule of
// dvr_gl/renderers/shearwarp/factorization.py's pyramid_of (the largest component, ties to the
// lower axis); the other pyramids' draws fill the rest.
uniform sampler2D u_intermediate;
in vec2 texcoord;
out vec4 frag_color;

#ifdef PYRAMID
uniform mat3 u_pixel_dirs;     // (px, py, 1) -> the pixel's ray direction in voxel units
uniform int u_pyramid_axis;
uniform float u_pyramid_sign;
uniform float u_image_height;

bool in_pyramid() {
    // pixel coordinates as the host's: px = col + 0.5, py = row + 0.5 with row 0 at the top
    vec3 d = u_pixel_dirs * vec3(gl_FragCoord.x, u_image_height - gl_FragCoord.y, 1.0);
    vec3 a = abs(d);
    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    return axis == u_pyramid_axis && d[axis] * u_pyramid_sign > 0.0;
}
#endif

void main() {
#ifdef PYRAMID
    if (!in_pyramid()) discard;
#endif
    frag_color = texture(u_intermediate, texcoord);
}
