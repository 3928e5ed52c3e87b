#version 430 core
// One sample of the central slice of the half spectra (dvr_gl/renderers/fourier/spectrum.py): this
// fragment's frequency (numpy's fftfreq order: fragment x is k, y is l) taken to the spectrum's index
// units, the spectra interpolated there with float weights (TRILINEAR, WINDOWED_SINC, KAISER_BESSEL, or the cubic
// B-spline), periodic, the half not stored read as the conjugate of its mirror.  TEXTURES textures of
// two complex channels each (.rg, .ba).  DEPTH_CUE: also the interpolant's derivative along
// u_depth_dir (the kernel's derivative weights), for the depth cue's moment
// (dvr_gl/renderers/fourier/projection.py, finish).  Outputs: the values of each texture's channels,
// then (DEPTH_CUE) their derivatives in the same order.

uniform sampler3D u_spectra[TEXTURES];  // (Mx / 2 + 1, My, Mz): re, im of two channels
#ifdef DEPTH_CUE
uniform vec3 u_depth_dir;         // f M h: the view axis in index units per world frequency
#define OUTPUTS (2 * TEXTURES)
#else
#define OUTPUTS TEXTURES
#endif
layout(location = 0) out vec4 frags[OUTPUTS];
uniform ivec3 u_dims;             // M per axis
uniform ivec2 u_size;             // the slice's samples (W', H')
uniform vec2 u_frequency_step;    // 1 / (W' p), 1 / (H' p): cycles per world unit
uniform vec3 u_right;             // the image's axes (world)
uniform vec3 u_down;
uniform vec3 u_grid_scale;        // M h: spectrum index units per cycle per world unit

// k mod M in [0, M): GLSL leaves % of negative operands undefined, so k is made positive first (the
// slice's indices stay within 1024 periods of zero: a pixel would have to be 500 times finer than a voxel)
ivec3 wrap(ivec3 k) {
    return (k + 1024 * u_dims) % u_dims;
}

// Where the spectrum at integer index k (any) is stored, and the conjugation that reads it.
ivec3 stored(ivec3 k, out vec4 conj) {
    ivec3 m = wrap(k);
    bool mirrored = m.x > u_dims.x / 2;
    conj = mirrored ? vec4(1.0, -1.0, 1.0, -1.0) : vec4(1.0);
    return mirrored ? wrap(-m) : m;
}

#ifdef TRILINEAR
const int TAPS = 2;
const int FIRST = 0;
void weights(float f, out float w[6], out float dw[6]) {
    w[0] = 1.0 - f; w[1] = f;
    dw[0] = -1.0; dw[1] = 1.0;
}
#elif defined(WINDOWED_SINC) || defined(KAISER_BESSEL)
// sinc(x) under a Kaiser window of half-width SLICE_TAPS / 2 (dvr_gl/renderers/fourier/spectrum.py), or
// KAISER_BESSEL: the window alone (kaiser_window, its shape from the padding)
const int TAPS = SLICE_TAPS;
const int FIRST = 1 - SLICE_TAPS / 2;
const float HALF_WIDTH = float(SLICE_TAPS) / 2.0;
uniform float u_kaiser_beta;
const float PI = 3.14159265358979;

// I0 and I1 by their power series (z <= beta <= 18: 30 terms reach float32)
void bessel(float z, out float i0, out float i1) {
    float q = 0.25 * z * z, t0 = 1.0, t1 = 0.5 * z;
    i0 = t0;
    i1 = t1;
    for (int k = 1; k < 30; ++k) {
        t0 *= q / float(k * k);
        t1 *= q / float(k * (k + 1));
        i0 += t0;
        i1 += t1;
    }
}

void kernel_at(float x, out float k, out float dk) {
    k = 0.0;
    dk = 0.0;
    if (abs(x) >= HALF_WIDTH)
        return;
    float u = x / HALF_WIDTH, root = sqrt(max(1.0 - u * u, 0.0));
    float i0, i1, n0, n1;
    bessel(u_kaiser_beta * root, i0, i1);
    bessel(u_kaiser_beta, n0, n1);
    float window = i0 / n0;
#ifdef KAISER_BESSEL
    float s = 1.0, ds = 0.0;
#else
    float s = abs(x) > 1e-6 ? sin(PI * x) / (PI * x) : 1.0;
    float ds = abs(x) > 1e-6 ? (cos(PI * x) - s) / x : 0.0;
#endif
    float dwindow = root > 1e-6 ? i1 * u_kaiser_beta * (-u / root) / HALF_WIDTH / n0 : 0.0;
    k = s * window;
    dk = ds * window + s * dwindow;
}

void weights(float f, out float w[6], out float dw[6]) {
    for (int o = 0; o < TAPS; ++o)
        kernel_at(f - float(o + FIRST), w[o], dw[o]);
}
#else
const int TAPS = 4;
const int FIRST = -1;
void weights(float f, out float w[6], out float dw[6]) {
    float f2 = f * f, f3 = f2 * f;
    w[0] = (1.0 - f) * (1.0 - f) * (1.0 - f) / 6.0;
    w[1] = (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0;
    w[2] = (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0;
    w[3] = f3 / 6.0;
    dw[0] = -(1.0 - f) * (1.0 - f) / 2.0;
    dw[1] = (3.0 * f2 - 4.0 * f) / 2.0;
    dw[2] = (-3.0 * f2 + 2.0 * f + 1.0) / 2.0;
    dw[3] = f2 / 2.0;
}
#endif

void main() {
    ivec2 kl = ivec2(gl_FragCoord.xy);
    vec2 index = vec2(kl.x < u_size.x / 2 ? kl.x : kl.x - u_size.x, kl.y < u_size.y / 2 ? kl.y : kl.y - u_size.y);
    vec2 uv = index * u_frequency_step;
    vec3 g = (uv.x * u_right + uv.y * u_down) * u_grid_scale;
    vec3 base = floor(g);
    vec3 f = g - base;
    ivec3 b = ivec3(base);
    float wx[6], wy[6], wz[6], dx[6], dy[6], dz[6];
    weights(f.x, wx, dx);
    weights(f.y, wy, dy);
    weights(f.z, wz, dz);
    vec4 sums[TEXTURES], slopes[TEXTURES];
    for (int t = 0; t < TEXTURES; ++t) {
        sums[t] = vec4(0.0);
        slopes[t] = vec4(0.0);
    }
    for (int z = 0; z < TAPS; ++z)
        for (int y = 0; y < TAPS; ++y)
            for (int x = 0; x < TAPS; ++x) {
                vec4 conj;
                ivec3 m = stored(b + ivec3(x + FIRST, y + FIRST, z + FIRST), conj);
                float w = wz[z] * wy[y] * wx[x];
#ifdef DEPTH_CUE
                float dw = u_depth_dir.x * dx[x] * wy[y] * wz[z] + u_depth_dir.y * wx[x] * dy[y] * wz[z]
                           + u_depth_dir.z * wx[x] * wy[y] * dz[z];
#endif
                for (int t = 0; t < TEXTURES; ++t) {
                    vec4 value = texelFetch(u_spectra[t], m, 0) * conj;
                    sums[t] += w * value;
#ifdef DEPTH_CUE
                    slopes[t] += dw * value;
#endif
                }
            }
    for (int t = 0; t < TEXTURES; ++t) {
        frags[t] = sums[t];
#ifdef DEPTH_CUE
        frags[TEXTURES + t] = slopes[t];
#endif
    }
}
