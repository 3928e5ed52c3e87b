// The pre-integration table (dvr_gl.preintegration): (associated colour, optical depth) of a
// segment of the table's length by its front and back values, interpolated bilinearly with float
// weights (texelFetch and mix) as the reference interpolates it.  x = front, y = back.

uniform sampler2D u_preint;      // N x N, RGBA32F
uniform int u_preint_size;
uniform float u_preint_lo;       // value of node 0
uniform float u_preint_scale;    // nodes per data unit: (N - 1) / (hi - lo)

vec4 preintegrated(float front, float back) {
    float last = float(u_preint_size - 1);
    vec2 x = clamp((vec2(front, back) - u_preint_lo) * u_preint_scale, 0.0, last);
    ivec2 i0 = min(ivec2(floor(x)), ivec2(u_preint_size - 2));
    vec2 f = x - vec2(i0);
    vec4 a = mix(texelFetch(u_preint, i0, 0), texelFetch(u_preint, i0 + ivec2(1, 0), 0), f.x);
    vec4 b = mix(texelFetch(u_preint, i0 + ivec2(0, 1), 0), texelFetch(u_preint, i0 + ivec2(1, 1), 0), f.x);
    return mix(a, b, f.y);
}

// The entry of a segment `fraction` as long (the shortened last one; or a scaled optical depth):
// optical depth scaled, colour with the opacity (exact for constant material).
vec4 shorten(vec4 entry, float fraction) {
    float alpha = opacity_of_depth(entry.a);
    float scaled = opacity_of_depth(entry.a * fraction);
    return vec4(alpha > 0.0 ? entry.rgb * (scaled / alpha) : entry.rgb * fraction, entry.a * fraction);
}
