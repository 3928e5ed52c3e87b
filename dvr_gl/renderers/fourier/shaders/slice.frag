#version 430 core
// One sample of the central slice of the half spectra (dvr_gl/renderers/fourier/spectrum.py), times the
// reconstruction filter's transform: H(w) = S(w M h) Phi(w).  Fragment (k, l) is the frequency of numpy's
// fftfreq order, k in 0 .. W' / 2 only: the projection is real, so its transform is Hermitian and the
// host's inverse is irfft2 of this half (dvr_gl/renderers/fourier/projection.py, finish).  The frequency
// is taken to the spectrum's index units and the spectra interpolated there with float weights
// (TRILINEAR, the windowed kernels' TABLE, or the cubic B-spline), periodic, the half not stored read as
// the conjugate of its mirror.  TEXTURES textures of two complex channels each (.rg, .ba).  DEPTH_CUE:
// also H's derivative along the view, d Phi + S (f . grad Phi) (d: the interpolant's derivative along
// u_depth_dir, from the kernel's derivative weights), for the depth cue's moment.  Outputs: H of each
// texture's channels, then (DEPTH_CUE) their derivatives in the same order.

uniform sampler3D u_spectra[TEXTURES];  // (Mx / 2 + 1 + 2 XPAD, My, Mz), x from -XPAD: re, im of two channels
#ifdef DEPTH_CUE
uniform vec3 u_depth_dir;         // f M h: the view axis in index units per world frequency
uniform vec3 u_forward;           // f: the view axis (world)
#define OUTPUTS (2 * TEXTURES)
#else
#define OUTPUTS TEXTURES
#endif
layout(location = 0) out vec4 frags[OUTPUTS];
uniform ivec3 u_dims;             // M per axis
uniform ivec2 u_size;             // the slice's full grid (W', H'); W' / 2 + 1 columns are drawn
uniform vec2 u_frequency_step;    // 1 / (W' p), 1 / (H' p): cycles per world unit
uniform vec3 u_right;             // the image's axes (world)
uniform vec3 u_down;
uniform vec3 u_grid_scale;        // M h: spectrum index units per cycle per world unit
uniform vec3 u_spacing;           // h: the voxels' spacing (world)
uniform float u_filter_scale;     // the voxel's volume (Phi's factor)
#ifdef FILTER_GAUSSIAN
uniform float u_kernel_width;     // sigma (voxels)
#endif

const float PI = 3.14159265358979;

// The reconstruction filter's transform at world frequency w (projection.py, filter_transform), and its
// derivative along f (filter_derivative): the Gaussian's, or the tent's (FILTER_POWER 2) or the cubic
// B-spline's (4) sinc powers per axis.
float sinc(float x) {
    return abs(x) > 1e-4 ? sin(PI * x) / (PI * x) : 1.0 - (PI * PI / 6.0) * x * x;
}

float sinc_slope(float x) {  // d sinc / dx
    return abs(x) > 1e-4 ? (cos(PI * x) - sinc(x)) / x : -(PI * PI / 3.0) * x;
}

void filter_transform(vec3 w, vec3 f, out float phi, out float dphi) {
    vec3 wh = w * u_spacing;
#ifdef FILTER_GAUSSIAN
    float c = 2.0 * PI * PI * u_kernel_width * u_kernel_width;
    phi = exp(-c * dot(wh, wh)) * u_filter_scale;
    dphi = phi * (-2.0 * c) * dot(wh * u_spacing, f);
#else
    vec3 s = vec3(sinc(wh.x), sinc(wh.y), sinc(wh.z));
    vec3 s2 = s * s;
    vec3 p = FILTER_POWER == 2 ? s2 : s2 * s2;
    phi = p.x * p.y * p.z * u_filter_scale;
    vec3 ds = vec3(sinc_slope(wh.x), sinc_slope(wh.y), sinc_slope(wh.z));
    // d/dw_a of s_a^n = n s_a^(n - 1) ds_a h_a
    vec3 lead = float(FILTER_POWER) * (FILTER_POWER == 2 ? s : s2 * s) * ds * u_spacing;
    dphi = (f.x * lead.x * p.y * p.z + f.y * p.x * lead.y * p.z + f.z * p.x * p.y * lead.z) * u_filter_scale;
#endif
}

#ifdef TRILINEAR
const int TAPS = 2;
const int FIRST = 0;
void weights(float f, out float w[6], out float dw[6]) {
    w[0] = 1.0 - f; w[1] = f;
    dw[0] = -1.0; dw[1] = 1.0;
}
#elif defined(TABLE)
// The windowed kernels (sinc under a Kaiser window, or the Kaiser-Bessel window alone: spectrum.py,
// kernel) of half-width SLICE_TAPS / 2, from their table: (k, dk/dx) at TABLE evenly spaced |x| from 0 to
// the half-width (the last zero), linearly interpolated (renderer.py, KernelTable: within 1e-7 of the kernel)
const int TAPS = SLICE_TAPS;
const int FIRST = 1 - SLICE_TAPS / 2;
const float HALF_WIDTH = float(SLICE_TAPS) / 2.0;
uniform sampler2D u_kernel;       // (TABLE, 1): k, dk at |x|

void kernel_at(float x, out float k, out float dk) {
    float t = min(abs(x) * (float(TABLE - 1) / HALF_WIDTH), float(TABLE - 1));
    int i = min(int(t), TABLE - 2);
    vec2 v = mix(texelFetch(u_kernel, ivec2(i, 0), 0).rg, texelFetch(u_kernel, ivec2(i + 1, 0), 0).rg, t - float(i));
    k = v.x;
    dk = x < 0.0 ? -v.y : v.y;  // k is even, its derivative odd
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

// k mod M in [0, M), by a float division (its floor within one of k / M for |k| < 2^22: the slice's indices
// stay far below) and a correction either way; not %, which GLSL leaves undefined for negative operands and
// a CPU's SIMD units (llvmpipe) divide lane by lane (the slice pass 1.05-1.15x faster at 256^3, 512x512)
int wrap(int k, int m) {
    int r = k - m * int(floor(float(k) / float(m)));
    return r < 0 ? r + m : (r >= m ? r - m : r);
}

// The taps one texel read each (and, DEPTH_CUE, the derivative weights): TAPS^3 reads.
void tap_sums(ivec3 b, float wx[6], float wy[6], float wz[6], float dx[6], float dy[6], float dz[6],
              inout vec4 sums[TEXTURES], inout vec4 slopes[TEXTURES]) {
    // each axis's taps wrapped once, and their mirrors: a tap whose x lies in the half not stored is read
    // at -k, conjugated
    int mx[6], my[6], mz[6], nx[6], ny[6], nz[6];
    bool mirrored[6];
    for (int o = 0; o < TAPS; ++o) {
        mx[o] = wrap(b.x + o + FIRST, u_dims.x);
        my[o] = wrap(b.y + o + FIRST, u_dims.y);
        mz[o] = wrap(b.z + o + FIRST, u_dims.z);
        nx[o] = wrap(-mx[o], u_dims.x);
        ny[o] = wrap(-my[o], u_dims.y);
        nz[o] = wrap(-mz[o], u_dims.z);
        mirrored[o] = mx[o] > u_dims.x / 2;
    }
    for (int x = 0; x < TAPS; ++x) {
        vec4 conj = mirrored[x] ? vec4(1.0, -1.0, 1.0, -1.0) : vec4(1.0);
        for (int z = 0; z < TAPS; ++z)
            for (int y = 0; y < TAPS; ++y) {
                ivec3 m = mirrored[x] ? ivec3(nx[x], ny[y], nz[z]) : ivec3(mx[x], my[y], mz[z]);
                m.yz = ivec2(wrap(m.y + ROLL, u_dims.y), wrap(m.z + ROLL, u_dims.z));  // the stored rows
                float w = wz[z] * wy[y] * wx[x];
#ifdef DEPTH_CUE
                float dw = u_depth_dir.x * dx[x] * wy[y] * wz[z] + u_depth_dir.y * wx[x] * dy[y] * wz[z]
                           + u_depth_dir.z * wx[x] * wy[y] * dz[z];
#endif
                for (int t = 0; t < TEXTURES; ++t) {
                    vec4 value = texelFetch(u_spectra[t], m + ivec3(XPAD, 0, 0), 0) * conj;
                    sums[t] += w * value;
#ifdef DEPTH_CUE
                    slopes[t] += dw * value;
#endif
                }
            }
    }
}

#ifdef PAIRED_TAPS
// The taps two by two (the weights are positive: the Kaiser-Bessel and cubic B-spline slices'; DEPTH_CUE
// never): the pair (k, k + 1) of weights (w0, w1) is one linearly filtered read at k + w1 / (w0 + w1) times
// w0 + w1, so the TAPS^3 texel reads become (TAPS / 2)^3 trilinear ones (LINEAR textures, y and z periodic).
// The fragment's g has its x in [0, M/2] (main: mirrored whole where it is not), and the textures hold
// XPAD columns of the half not stored on either side, so every pair is one read, with no branch and no
// array indexed per fragment (llvmpipe keeps those in memory lane by lane).
const int PAIRS = TAPS / 2;

// Pair p of an axis (y or z) of the taps from b + FIRST: its weight and its row (index units, the rolled
// texture's).  The row's integer part is wrapped exactly: the filtered read's precision falls with the row
// (llvmpipe: about row x 6e-8 texels), so the large low frequencies (rows near ROLL) are read precisely.
void pair_row(int b, int m, float w[6], int p, out float row, out float weight) {
    weight = w[2 * p] + w[2 * p + 1];
    row = float(wrap(b + FIRST + 2 * p + ROLL, m)) + w[2 * p + 1] / weight;
}

void paired_sums(ivec3 b, float wx[6], float wy[6], float wz[6], inout vec4 sums[TEXTURES]) {
    float rx[PAIRS], qx[PAIRS], ry[PAIRS], qy[PAIRS], rz[PAIRS], qz[PAIRS];
    for (int p = 0; p < PAIRS; ++p) {
        qx[p] = wx[2 * p] + wx[2 * p + 1];
        rx[p] = float(b.x + FIRST + 2 * p + XPAD) + wx[2 * p + 1] / qx[p];  // the column: x + XPAD
        pair_row(b.y, u_dims.y, wy, p, ry[p], qy[p]);
        pair_row(b.z, u_dims.z, wz, p, rz[p], qz[p]);
    }
    vec3 texels = vec3(float(u_dims.x / 2 + 1 + 2 * XPAD), vec2(u_dims.yz));
    for (int x = 0; x < PAIRS; ++x)
        for (int z = 0; z < PAIRS; ++z)
            for (int y = 0; y < PAIRS; ++y) {
                vec3 at = (vec3(rx[x], ry[y], rz[z]) + 0.5) / texels;
                float w = qx[x] * qy[y] * qz[z];
                for (int t = 0; t < TEXTURES; ++t)
                    sums[t] += w * textureLod(u_spectra[t], at, 0.0);
            }
}
#endif

void main() {
    ivec2 kl = ivec2(gl_FragCoord.xy);
    vec2 index = vec2(kl.x < u_size.x / 2 ? kl.x : kl.x - u_size.x, kl.y < u_size.y / 2 ? kl.y : kl.y - u_size.y);
    vec2 uv = index * u_frequency_step;
    vec3 w = uv.x * u_right + uv.y * u_down;
    vec3 g = w * u_grid_scale;
#ifdef PAIRED_TAPS
    // S(-g) is the conjugate of S(g) and the kernel is even: where g's x lies in the half not stored (wrapped
    // to [-M/2, M/2): the subtraction of a whole period is exact), the fragment is read at -g and conjugated
    float period = float(u_dims.x);
    g.x -= period * floor(g.x / period + 0.5);
    bool mirrored = g.x < 0.0;
    g = mirrored ? -g : g;
#endif
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
#ifdef PAIRED_TAPS
    paired_sums(b, wx, wy, wz, sums);
    for (int t = 0; t < TEXTURES; ++t)
        sums[t] *= mirrored ? vec4(1.0, -1.0, 1.0, -1.0) : vec4(1.0);
#else
    tap_sums(b, wx, wy, wz, dx, dy, dz, sums, slopes);
#endif
    float phi, dphi;
#ifdef DEPTH_CUE
    filter_transform(w, u_forward, phi, dphi);
#else
    filter_transform(w, vec3(0.0), phi, dphi);
#endif
    for (int t = 0; t < TEXTURES; ++t) {
        frags[t] = phi * sums[t];
#ifdef DEPTH_CUE
        frags[TEXTURES + t] = phi * slopes[t] + dphi * sums[t];
#endif
    }
}
