// An SPH particle's cubic-spline kernel (M4, support R = 2h) along this pixel's ray, from the tables
// of dvr_gl/renderers/splatting/footprint.py (M4Footprint), read with float weights.  Two ways:
// * m4_integral: the kernel's integral along the pixel's own ray over [lo, hi] (the ray's part in the
//   slab), exact in both projections (the kernel is a sphere in world units);
// * m4_pixel_average (a particle smaller than a pixel): the footprint averaged over the pixel's
//   square, seen along the view axis at the particle's depth, from the quadrant table G: the pixels a
//   particle covers share its integral exactly (G's differences telescope), where point samples at
//   pixel centres would miss it or multiply it.
// Requires table_1d (kernel.glsl).

uniform sampler2D u_m4_footprint;  // h^2 F at q = rho^2 / R^2 in [0, 1]: one row
uniform sampler2D u_m4_chord;      // share of a line's integral below xi in [-1, 1] of its chord; rows: q
uniform sampler2D u_m4_box;        // G(X, Y): the footprint's share over (-1, X) x (-1, Y), X, Y in [-1, 1] (units of R)
uniform sampler2D u_m4_slab;       // the kernel's mass below the plane Z in [-1, 1] (units of R): one row

// bilinear, texel centres at the ends of [0, 1]^2 (x: columns, y: rows)
float table_2d(sampler2D table, vec2 uv) {
    ivec2 n = textureSize(table, 0);
    vec2 f = clamp(uv, 0.0, 1.0) * vec2(n - 1);
    ivec2 i = min(ivec2(f), n - 2);
    vec2 w = f - vec2(i);
    float a = mix(texelFetch(table, i, 0).r, texelFetch(table, i + ivec2(1, 0), 0).r, w.x);
    float b = mix(texelFetch(table, i + ivec2(0, 1), 0).r, texelFetch(table, i + ivec2(1, 1), 0).r, w.x);
    return mix(a, b, w.y);
}

float m4_chord_share(float q, float xi) {
    return table_2d(u_m4_chord, vec2(xi * 0.5 + 0.5, q));
}

// The kernel centred at `centre` (smoothing length h, world units) integrated along the ray over [lo, hi].
// As kernel_integral (kernel.glsl): the ray is taken from its point at lo, which every splat of the
// pixel shares.
float m4_integral(vec3 o, vec3 d, vec3 centre, float h, float lo, float hi) {
    float R = 2.0 * h;
    vec3 uo = (o + lo * d - centre) / R;
    vec3 ud = d / R;
    float a = dot(ud, ud);
    float tc = -dot(uo, ud) / a;               // the nearest approach, from lo
    vec3 nearest = uo + tc * ud;
    float q = dot(nearest, nearest);
    if (q >= 1.0)
        return 0.0;
    float len = sqrt(a);                       // units of R per world unit along the ray
    float c = sqrt(1.0 - q);                   // the half chord, units of R
    float x0 = -tc * len, x1 = (hi - lo - tc) * len;
    if (x1 <= -c || x0 >= c)
        return 0.0;
    float share = 1.0;
    if (x0 > -c || x1 < c)
        share = m4_chord_share(q, min(x1 / c, 1.0)) - m4_chord_share(q, max(x0 / c, -1.0));
    // h^2 F / h^2, per unit of the ray's parameter
    return table_1d(u_m4_footprint, q) / (h * h) * share / (len * R);
}

float m4_box(float x, float y) {
    return table_2d(u_m4_box, vec2(x, y) * 0.5 + 0.5);
}

// The footprint's mean over this pixel, seen along the view axis at the particle's depth; the pixel's
// edges are whole pixel numbers mapped alike by every fragment, so neighbours share them exactly.
// ndc_per_world: the screen's NDC units per world unit at the particle's depth (x, y).
float m4_pixel_average(vec3 centre, float h, vec2 ndc_per_world) {
    float R = 2.0 * h;
    vec2 pixel = floor(gl_FragCoord.xy);
    vec2 ndc0 = pixel / u_image_size * 2.0 - 1.0;
    vec2 ndc1 = (pixel + 1.0) / u_image_size * 2.0 - 1.0;
    vec2 c = vec2(dot(centre - u_eye, u_right), dot(centre - u_eye, u_up)) * ndc_per_world;  // centre in NDC
    vec2 lo = clamp((ndc0 - c) / (R * ndc_per_world), -1.0, 1.0);
    vec2 hi = clamp((ndc1 - c) / (R * ndc_per_world), -1.0, 1.0);
    float mass = m4_box(hi.x, hi.y) - m4_box(lo.x, hi.y) - m4_box(hi.x, lo.y) + m4_box(lo.x, lo.y);
    vec2 area = (ndc1 - ndc0) / ndc_per_world;  // the pixel's square at the particle's depth, world units
    return mass / (area.x * area.y);
}

// The kernel's share between the view depths z0 < z1 (a slab), the particle at depth z.
float m4_slab_share(float z, float h, float z0, float z1) {
    float R = 2.0 * h;
    float a = clamp((z0 - z) / R, -1.0, 1.0), b = clamp((z1 - z) / R, -1.0, 1.0);
    return table_1d(u_m4_slab, b * 0.5 + 0.5) - table_1d(u_m4_slab, a * 0.5 + 0.5);
}
