// The transfer-function table (dvr_gl.transfer_function.TransferFunctionLUT): N texels of
// (r, g, b, sigma) at evenly spaced data values, interpolated here with a float weight
// (texelFetch and mix), so every GPU looks it up as the reference does.

uniform sampler2D u_lut;        // N x 1, RGBA32F
uniform int u_lut_size;
uniform float u_lut_lo;         // data value of texel 0
uniform float u_lut_scale;      // texels per data unit: (N - 1) / (hi - lo)

// (non-associated colour, extinction sigma per world unit) at a data value
vec4 transfer_function(float value) {
    float x = clamp((value - u_lut_lo) * u_lut_scale, 0.0, float(u_lut_size - 1));
    int i0 = min(int(floor(x)), u_lut_size - 2);
    return mix(texelFetch(u_lut, ivec2(i0, 0), 0), texelFetch(u_lut, ivec2(i0 + 1, 0), 0), x - float(i0));
}

#ifdef ALBEDO_TABLE
uniform sampler2D u_albedo_lut;  // N x 1, RGBA32F: the albedo column in r, at u_lut's data values

// single scattering's albedo at a data value (the transfer function's sixth column)
float albedo_table(float value) {
    float x = clamp((value - u_lut_lo) * u_lut_scale, 0.0, float(u_lut_size - 1));
    int i0 = min(int(floor(x)), u_lut_size - 2);
    return mix(texelFetch(u_albedo_lut, ivec2(i0, 0), 0).r, texelFetch(u_albedo_lut, ivec2(i0 + 1, 0), 0).r,
               x - float(i0));
}
#endif
