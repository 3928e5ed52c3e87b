#version 400 core
// The shell pass of Fourier rendering (dvr_gl/renderers/fourier/projection.py, shell_integrals): per
// pixel, the integral of the ghosted channels along the whole line outside the volume's box, which the
// inverse transform includes and the references' clipped chords do not.  The ghosted field is zero
// beyond u_outer; between the voxel planes it is a polynomial along the ray (the trilinear field's
// degree 3, the cubic B-spline's 9), so each piece is integrated by NODES-point Gauss-Legendre.
// CUBIC_BSPLINE: the cubic B-spline field (64 taps), else the trilinear (8): float weights and
// texelFetch, not the texture unit's filtering (its weights have 8 fractional bits on most hardware),
// each cell's taps fetched once per piece.
// FACES (the trilinear field): a walk over the six faces' 2D layers instead (integrate_faces), half the
// taps a piece from a texture of the faces' size; GATHER (one channel): one read a piece.
// Fragment (i, j) is the image's pixel i from the left, row j from the top.

#ifdef FACES
// The faces' sample layers zero-padded by one texel, layer 2 a + side the axis a's low (side 0) or high face:
// texel (i, j) is sample (i - 1, j - 1) along the face's two other axes in order (x: (y, z), y: (x, z), z:
// (x, y)); zeros beyond (the layers have the largest face's size).
uniform sampler2DArray u_faces;
#else
uniform sampler3D u_field;        // the ghosted channels, zero-padded: texel n at world u_origin + n h
uniform ivec3 u_texels;
uniform vec3 u_origin;
#endif
uniform vec3 u_spacing;
uniform vec3 u_box_lo;            // the volume's box (the references' chords)
uniform vec3 u_box_hi;
uniform vec3 u_outer_lo;          // where the ghosted field ends
uniform vec3 u_outer_hi;
uniform vec3 u_corner;            // the top-left pixel's centre on the eye's plane
uniform vec3 u_right;             // the image's axes and the view (world, unit)
uniform vec3 u_down;
uniform vec3 u_forward;
uniform vec3 u_eye;
uniform float u_pixel;            // the pixel's width (world)
uniform vec2 u_cue;               // a, b: the depth cue's weight a + b z at view depth z
uniform vec4 u_weighted;          // 1 for the channels the cue weights
uniform float u_nodes[NODES];     // Gauss-Legendre on [-1, 1]
uniform float u_node_weights[NODES];
uniform int u_max_pieces;         // the longest stretch's voxel planes: a bound on the loop
out vec4 frag;

#ifndef FACES
vec4 tap(ivec3 n) {
    return texelFetch(u_field, clamp(n, ivec3(0), u_texels - 1), 0);
}

// The field in one cell (b, b + 1): its taps fetched once per piece (a piece lies in one cell), then
// evaluated at each node's fraction f.
#ifdef CUBIC_BSPLINE
#define TAPS 64
void bspline(float f, out float w[4]) {
    float g = 1.0 - f;
    w[0] = g * g * g / 6.0;
    w[1] = (3.0 * f * f * f - 6.0 * f * f + 4.0) / 6.0;
    w[2] = (-3.0 * f * f * f + 3.0 * f * f + 3.0 * f + 1.0) / 6.0;
    w[3] = f * f * f / 6.0;
}

void load(ivec3 b, out vec4 taps[TAPS]) {
    for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i)
                taps[(k * 4 + j) * 4 + i] = tap(b + ivec3(i - 1, j - 1, k - 1));
}

vec4 field(vec4 taps[TAPS], vec3 f) {
    float wx[4], wy[4], wz[4];
    bspline(f.x, wx);
    bspline(f.y, wy);
    bspline(f.z, wz);
    vec4 sum = vec4(0.0);
    for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 4; ++j) {
            float wzy = wz[k] * wy[j];
            for (int i = 0; i < 4; ++i)
                sum += (wzy * wx[i]) * taps[(k * 4 + j) * 4 + i];
        }
    return sum;
}
#else
#define TAPS 8
void load(ivec3 b, out vec4 taps[TAPS]) {
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i)
                taps[(k * 2 + j) * 2 + i] = tap(b + ivec3(i, j, k));
}

vec4 field(vec4 taps[TAPS], vec3 f) {
    vec4 y0 = mix(mix(taps[0], taps[1], f.x), mix(taps[2], taps[3], f.x), f.y);
    vec4 y1 = mix(mix(taps[4], taps[5], f.x), mix(taps[6], taps[7], f.x), f.y);
    return mix(y0, y1, f.z);
}
#endif

#endif

// Entry and exit of the box [lo, hi] (slab method; a ray along a slab is inside while its origin is).
vec2 slab(vec3 o, vec3 d, vec3 lo, vec3 hi) {
    float t0 = -1e30, t1 = 1e30;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a]) return vec2(1.0, 0.0);
        } else {
            float ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return vec2(t0, t1);
}

// The depth cue's weight at view depth z for each channel (1 for those it does not weight); CUED: there is a
// cue (without it, 1: a quarter of the pass's time at 512x512 went to weighing by 1).
vec4 cue(float z) {
#ifdef CUED
    return mix(vec4(1.0), vec4(u_cue.x + u_cue.y * z), u_weighted);
#else
    return vec4(1.0);
#endif
}

#ifdef FACES
// The parameters where a line o + t d has its coordinate between lo and hi (all or none along the slab).
vec2 range(float o, float d, float lo, float hi) {
    if (d == 0.0) return (o < lo || o > hi) ? vec2(1e30, -1e30) : vec2(-1e30, 1e30);
    float ta = (lo - o) / d, tb = (hi - o) / d;
    return vec2(min(ta, tb), max(ta, tb));
}

// The parameters where the line is beyond the low face (side 0: index in [-1, 0)) or the high one (side 1:
// (last, last + 1]); a line in a face's plane is within the box, as the references' chords have it.
vec2 beyond(float o, float d, float last, int side) {
    if (d != 0.0) return side == 0 ? range(o, d, -1.0, 0.0) : range(o, d, last, last + 1.0);
    bool in_shell = side == 0 ? o < 0.0 && o >= -1.0 : o > last && o <= last + 1.0;
    return in_shell ? vec2(-1e30, 1e30) : vec2(1e30, -1e30);
}

// The weighted channels' integral beyond one face (axis a, layer side: 0 low, 1 high) over the line's
// parameters [ta, tb] (within a voxel of the face): there the trilinear field is (1 - s) times the face
// layer's bilinear interpolant, s the distance beyond the face in voxels, so the pieces lie between the
// face's own voxel planes (axes b < c, the face's texel columns and rows), each by Gauss-Legendre.  uo, ud:
// the line in sample units from the box's low corner; last: the last sample's index per axis.
vec4 walk(int side, int a, int b, int c, vec3 uo, vec3 ud, vec3 last, float z0,
          float ta, float tb) {
    vec4 sum = vec4(0.0);
    vec2 qo = vec2(uo[b], uo[c]) + 1.0, qd = vec2(ud[b], ud[c]);  // texel units (the padding's texel)
    ivec2 top = textureSize(u_faces, 0).xy - 2;
    int layer = 2 * a + side;
    // s = sa + t sd
    float sa = side == 0 ? -uo[a] : uo[a] - last[a], sd = side == 0 ? -ud[a] : ud[a];
    float t = ta;
    for (int piece = 0; piece < u_max_pieces && t < tb; ++piece) {
        vec2 q = qo + (t + 1e-5 * max(1.0, t)) * qd;  // nudged inward, as in integrate
        float next = tb;
        for (int k = 0; k < 2; ++k) {
            if (qd[k] > 0.0) next = min(next, (floor(q[k]) + 1.0 - qo[k]) / qd[k]);
            else if (qd[k] < 0.0) next = min(next, (ceil(q[k]) - 1.0 - qo[k]) / qd[k]);
        }
        float half_length = 0.5 * (next - t);
        ivec2 cell = clamp(ivec2(floor(qo + (t + half_length) * qd)), ivec2(0), top);
#ifdef GATHER
        // one channel: the cell's four texels in one read (its corner, between their centres)
        vec4 g = textureGather(u_faces, vec3((vec2(cell) + 1.0) / vec2(top + 2), float(layer)), 0);
        vec4 t00 = vec4(g.w), t10 = vec4(g.z), t01 = vec4(g.x), t11 = vec4(g.y);
#else
        vec4 t00 = texelFetch(u_faces, ivec3(cell, layer), 0), t10 = texelFetch(u_faces, ivec3(cell + ivec2(1, 0), layer), 0);
        vec4 t01 = texelFetch(u_faces, ivec3(cell + ivec2(0, 1), layer), 0), t11 = texelFetch(u_faces, ivec3(cell + 1, layer), 0);
#endif
        for (int k = 0; k < NODES; ++k) {
            float s = t + half_length * (u_nodes[k] + 1.0);
            vec2 f = qo + s * qd - vec2(cell);
            float fall = (half_length * u_node_weights[k]) * (1.0 - (sa + s * sd));
            sum += fall * cue(z0 + s) * mix(mix(t00, t10, f.x), mix(t01, t11, f.x), f.y);
        }
        t = next;
    }
    return sum;
}

// The whole line's integral beyond the box, from the shell's entry: the part with its x beyond the box,
// then y beyond it with x within, then z with x and y within (the shell, cut into six pieces).
vec4 integrate_faces(vec3 entry, float z0) {
    vec3 uo = (entry - u_box_lo) / u_spacing, ud = u_forward / u_spacing;
    vec3 last = (u_box_hi - u_box_lo) / u_spacing;
    vec4 sum = vec4(0.0);
    for (int a = 0; a < 3; ++a) {
        vec2 within = vec2(-1e30, 1e30);  // the other axes: those before a within the box, the rest the shell
        for (int k = 0; k < 3; ++k) {
            if (k == a) continue;
            vec2 r = k < a ? range(uo[k], ud[k], 0.0, last[k]) : range(uo[k], ud[k], -1.0, last[k] + 1.0);
            within = vec2(max(within.x, r.x), min(within.y, r.y));
        }
        for (int side = 0; side < 2; ++side) {
            vec2 r = beyond(uo[a], ud[a], last[a], side);
            float ta = max(r.x, within.x), tb = min(r.y, within.y);
            if (ta >= tb) continue;
            sum += walk(side, a, a == 0 ? 1 : 0, a == 2 ? 1 : 2, uo, ud, last, z0, ta, tb);
        }
    }
    return sum;
}
#else
// The weighted channels' integral over [ta, tb], piece by piece between the voxel planes.
vec4 integrate(vec3 o, float ta, float tb) {
    vec4 sum = vec4(0.0);
    vec3 uo = (o - u_origin) / u_spacing;  // index units: sample n at integer n
    vec3 ud = u_forward / u_spacing;
    float z0 = dot(o - u_eye, u_forward);
    float t = ta;
    for (int piece = 0; piece < u_max_pieces && t < tb; ++piece) {
        // the next voxel plane along each axis, from the piece's start nudged inward (a start on a
        // plane would find that plane again)
        vec3 u = uo + (t + 1e-5 * max(1.0, t)) * ud;
        float next = tb;
        for (int a = 0; a < 3; ++a) {
            if (ud[a] > 0.0) next = min(next, (floor(u[a]) + 1.0 - uo[a]) / ud[a]);
            else if (ud[a] < 0.0) next = min(next, (ceil(u[a]) - 1.0 - uo[a]) / ud[a]);
        }
        float half_length = 0.5 * (next - t);
        ivec3 cell = ivec3(floor(uo + (t + half_length) * ud));
        vec4 taps[TAPS];
        load(cell, taps);
        for (int k = 0; k < NODES; ++k) {
            float s = t + half_length * (u_nodes[k] + 1.0);
            sum += (half_length * u_node_weights[k]) * cue(z0 + s) * field(taps, uo + s * ud - vec3(cell));
        }
        t = next;
    }
    return sum;
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec3 o = u_corner + (float(pixel.x) * u_pixel) * u_right + (float(pixel.y) * u_pixel) * u_down;
    vec2 outer = slab(o, u_forward, u_outer_lo, u_outer_hi);
    vec2 box = slab(o, u_forward, u_box_lo, u_box_hi);
    // parameters from the shell's entry, to keep them small in float32
    vec3 entry = o + outer.x * u_forward;
    outer -= outer.x;
    box -= vec2(dot(entry - o, u_forward));
    if (outer.y <= 0.0) {
        frag = vec4(0.0);
#ifdef FACES
    } else {
        frag = integrate_faces(entry, dot(entry - u_eye, u_forward));
#else
    } else if (box.x < box.y) {
        frag = integrate(entry, 0.0, box.x) + integrate(entry, box.y, outer.y);
    } else {
        frag = integrate(entry, 0.0, outer.y);
#endif
    }
}
