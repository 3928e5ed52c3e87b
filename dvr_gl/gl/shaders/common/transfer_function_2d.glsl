// A 2D transfer function's table (dvr_gl.transfer_function_2d.TransferFunction2DLUT): NV x NG texels of
// (r, g, b, sigma) at evenly spaced values (x) and gradient magnitudes (y), interpolated here with float
// weights (texelFetch and mix: along value, then along gradient magnitude), as the reference looks it up.

uniform sampler2D u_tf2d;       // NV x NG, RGBA32F
uniform ivec2 u_tf2d_size;      // (NV, NG)
uniform vec2 u_tf2d_lo;         // value and gradient magnitude of texel (0, 0)
uniform vec2 u_tf2d_scale;      // texels per data unit, per (value unit per world unit)

// (non-associated colour, extinction sigma per world unit) at a value and gradient magnitude
vec4 transfer_function_2d(float value, float gradient_magnitude) {
    vec2 x = clamp((vec2(value, gradient_magnitude) - u_tf2d_lo) * u_tf2d_scale, vec2(0.0), vec2(u_tf2d_size - 1));
    ivec2 i0 = min(ivec2(floor(x)), u_tf2d_size - 2);
    vec2 f = x - vec2(i0);
    vec4 low = mix(texelFetch(u_tf2d, i0, 0), texelFetch(u_tf2d, i0 + ivec2(1, 0), 0), f.x);
    vec4 high = mix(texelFetch(u_tf2d, i0 + ivec2(0, 1), 0), texelFetch(u_tf2d, i0 + ivec2(1, 1), 0), f.x);
    return mix(low, high, f.y);
}
