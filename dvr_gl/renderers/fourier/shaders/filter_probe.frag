#version 430 core
// The linear filter's precision (renderer.py, FourierRenderer.filters_in_float): a (2, 2, 2) texture of
// each texel's x index read linearly at fractions t = fract(0.618... i) between its two columns (fragment
// i); out: the read minus t (about 1e-7 with float weights; up to 1 / 512 with 8-bit ones), and t.
uniform sampler3D u_texels;
layout(location = 0) out vec4 frag;

void main() {
    float t = fract((gl_FragCoord.x - 0.5) * 0.6180339887);
    frag = vec4(textureLod(u_texels, vec3((t + 0.5) / 2.0, 0.5, 0.5), 0.0).r - t, t, 0.0, 1.0);
}
