// Reconstruction of a 3D texture at voxel coordinate u (sample i at u = i), as
// dvr_gl.reference.reconstruction does it, with taps clamped to the edge.
//   FILTER_NEAREST | FILTER_LINEAR | FILTER_CUBIC_BSPLINE | FILTER_CATMULL_ROM
//   FILTER_IN_SHADER: interpolate with texelFetch and float weights (exact on any GPU)
//   instead of the texture unit's linear filtering (fast; weights of limited precision).

uniform vec3 u_world_to_voxel_scale;    // u = p * scale + offset
uniform vec3 u_world_to_voxel_offset;
uniform vec3 u_voxel_spacing;           // world size of one voxel step along x, y, z
uniform ivec3 u_dims;

vec3 voxel_coord(vec3 p) {
    return p * u_world_to_voxel_scale + u_world_to_voxel_offset;
}

// The _in variants take the texture's dims (several fields: each texture its own grid); the others read u_dims.
vec4 texel_in(sampler3D tex, ivec3 i, ivec3 dims) {
    return texelFetch(tex, clamp(i, ivec3(0), dims - 1), 0);
}

vec4 texel(sampler3D tex, ivec3 i) {
    return texel_in(tex, i, u_dims);
}

// Hardware linear fetch at voxel coordinate u (between texel centres).
vec4 linear_fetch_in(sampler3D tex, vec3 u, ivec3 dims) {
    return texture(tex, (u + 0.5) / vec3(dims));
}

vec4 linear_fetch(sampler3D tex, vec3 u) {
    return linear_fetch_in(tex, u, u_dims);
}

void cubic_weights(vec3 f, out vec3 w0, out vec3 w1, out vec3 w2, out vec3 w3) {
    vec3 f2 = f * f;
    vec3 f3 = f2 * f;
#if defined(FILTER_CUBIC_BSPLINE)
    vec3 g = 1.0 - f;
    w0 = g * g * g / 6.0;
    w1 = (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0;
    w2 = (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0;
    w3 = f3 / 6.0;
#else
    w0 = (-f3 + 2.0 * f2 - f) / 2.0;
    w1 = (3.0 * f3 - 5.0 * f2 + 2.0) / 2.0;
    w2 = (-3.0 * f3 + 4.0 * f2 + f) / 2.0;
    w3 = (f3 - f2) / 2.0;
#endif
}

vec4 sample_texture_in(sampler3D tex, vec3 u, ivec3 dims) {
#if defined(FILTER_NEAREST)
    return texel_in(tex, ivec3(floor(u + 0.5)), dims);
#elif defined(FILTER_LINEAR)
    vec3 uc = clamp(u, vec3(0.0), vec3(dims - 1));
  #ifdef FILTER_IN_SHADER
    ivec3 i0 = clamp(ivec3(floor(uc)), ivec3(0), max(dims - 2, ivec3(0)));
    vec3 f = uc - vec3(i0);
    vec4 c00 = mix(texel_in(tex, i0, dims), texel_in(tex, i0 + ivec3(1, 0, 0), dims), f.x);
    vec4 c10 = mix(texel_in(tex, i0 + ivec3(0, 1, 0), dims), texel_in(tex, i0 + ivec3(1, 1, 0), dims), f.x);
    vec4 c01 = mix(texel_in(tex, i0 + ivec3(0, 0, 1), dims), texel_in(tex, i0 + ivec3(1, 0, 1), dims), f.x);
    vec4 c11 = mix(texel_in(tex, i0 + ivec3(0, 1, 1), dims), texel_in(tex, i0 + ivec3(1, 1, 1), dims), f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
  #else
    return linear_fetch_in(tex, uc, dims);
  #endif
#else
    vec3 i = floor(u);
    vec3 w0, w1, w2, w3;
    cubic_weights(u - i, w0, w1, w2, w3);
  #ifdef FILTER_IN_SHADER
    vec3 w[4] = vec3[4](w0, w1, w2, w3);
    ivec3 base = ivec3(i) - 1;
    vec4 sum = vec4(0.0);
    for (int c = 0; c < 4; ++c)
        for (int b = 0; b < 4; ++b)
            for (int a = 0; a < 4; ++a)
                sum += w[a].x * w[b].y * w[c].z * texel_in(tex, base + ivec3(a, b, c), dims);
    return sum;
  #elif defined(FILTER_CUBIC_BSPLINE)
    // Sigg & Hadwiger (GPU Gems 2, ch. 20): all weights are positive, so each pair of taps
    // is one linear fetch between them; 8 fetches in 3D.
    vec3 g0 = w0 + w1;
    vec3 g1 = w2 + w3;
    vec3 h0 = i - 1.0 + w1 / g0;
    vec3 h1 = i + 1.0 + w3 / g1;
    vec4 sum = vec4(0.0);
    for (int c = 0; c < 2; ++c)
        for (int b = 0; b < 2; ++b)
            for (int a = 0; a < 2; ++a) {
                vec3 h = vec3(a == 0 ? h0.x : h1.x, b == 0 ? h0.y : h1.y, c == 0 ? h0.z : h1.z);
                float g = (a == 0 ? g0.x : g1.x) * (b == 0 ? g0.y : g1.y) * (c == 0 ? g0.z : g1.z);
                sum += g * linear_fetch_in(tex, h, dims);
            }
    return sum;
  #else
    // Catmull-Rom: the outer weights are negative, the inner two positive with a positive sum,
    // so per axis one linear fetch for the inner pair and one texel each for the outer taps
    // (27 fetches in 3D).
    vec3 w12 = w1 + w2;
    vec3 pos[3] = vec3[3](i - 1.0, i + w2 / w12, i + 2.0);
    vec3 wt[3] = vec3[3](w0, w12, w3);
    vec4 sum = vec4(0.0);
    for (int c = 0; c < 3; ++c)
        for (int b = 0; b < 3; ++b)
            for (int a = 0; a < 3; ++a)
                sum += wt[a].x * wt[b].y * wt[c].z * linear_fetch_in(tex, vec3(pos[a].x, pos[b].y, pos[c].z), dims);
    return sum;
  #endif
#endif
}

vec4 sample_texture(sampler3D tex, vec3 u) {
    return sample_texture_in(tex, u, u_dims);
}

// ---- the scalar field, in data units ----

uniform sampler3D u_volume;
uniform float u_value_scale;   // data value = texel * scale + offset
uniform float u_value_offset;

float sample_scalar_voxel(vec3 u) {
    return sample_texture(u_volume, u).r * u_value_scale + u_value_offset;
}

float sample_scalar(vec3 p) {
    return sample_scalar_voxel(voxel_coord(p));
}
