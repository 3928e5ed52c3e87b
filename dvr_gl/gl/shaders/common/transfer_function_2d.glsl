// A 2D transfer function's table (dvr_gl.transfer_function_2d.TransferFunction2DLUT): NV x NG texels of
// (r, g, b, sigma) at evenly spaced values (x) and gradient magnitudes (y), interpolated here with float
// weights (texelFetch and mix: along value, then along gradient magnitude), as the reference looks it up.

// (non-associated colour, extinction sigma per world unit) from the size.x x size.y block of `table` whose first
// texel is `origin` (several members' tables may share one texture), at a value and gradient magnitude; lo: the
// value and gradient magnitude of the block's first texel; scale: texels per unit along each
vec4 table_2d(sampler2D table, ivec2 origin, ivec2 size, vec2 lo, vec2 scale, float value, float gradient_magnitude) {
    vec2 x = clamp((vec2(value, gradient_magnitude) - lo) * scale, vec2(0.0), vec2(size - 1));
    ivec2 i0 = min(ivec2(floor(x)), size - 2);
    vec2 f = x - vec2(i0);
    ivec2 t = origin + i0;
    vec4 low = mix(texelFetch(table, t, 0), texelFetch(table, t + ivec2(1, 0), 0), f.x);
    vec4 high = mix(texelFetch(table, t + ivec2(0, 1), 0), texelFetch(table, t + ivec2(1, 1), 0), f.x);
    return mix(low, high, f.y);
}

uniform sampler2D u_tf2d;       // NV x NG, RGBA32F
uniform ivec2 u_tf2d_size;      // (NV, NG)
uniform vec2 u_tf2d_lo;         // value and gradient magnitude of texel (0, 0)
uniform vec2 u_tf2d_scale;      // texels per data unit, per (value unit per world unit)

// the scene's own 2D transfer function (one field)
vec4 transfer_function_2d(float value, float gradient_magnitude) {
    return table_2d(u_tf2d, ivec2(0), u_tf2d_size, u_tf2d_lo, u_tf2d_scale, value, gradient_magnitude);
}
