// A splat's kernel along this pixel's ray: the integral of the kernel over the part of the ray
// inside the volume's box (and inside a slab: SLABS), in world units, from the footprint tables
// (dvr_gl/renderers/splatting/footprint.py), read with float weights (texelFetch and mix).  Exact in both projections: the ray itself is taken
// into the kernel's voxel space, where the kernel is a sphere, so no footprint is approximated
// by an affine map.

uniform sampler2D u_footprint;  // F(q), q = rho^2 / R^2 in [0, 1]: one row, sigma = 1
uniform sampler2D u_cumulative; // Phi(x), the standard normal's share below x, x in [-u_sigmas, u_sigmas]
uniform float u_sigmas;         // the support's radius in standard deviations
uniform float u_sigma;          // the Gaussian's standard deviation, voxels
uniform vec3 u_box_lo;          // the volume's box, relative to its centre
uniform vec3 u_box_hi;
#ifdef SLABS
uniform vec2 u_slab;            // the slab's view depths (from the eye along the view axis)
#endif
#ifdef LOW_PASS
// EWA's screen low-pass (dvr_gl/renderers/splatting/low_pass.py), per splat from splat.vert: the widened
// kernel's metric G in voxel units (|u|^2 becomes u.G u) and sqrt(det G), its density's factor
flat in mat3 v_metric;
flat in float v_metric_root;
#endif

float table_1d(sampler2D table, float x) {
    int n = textureSize(table, 0).x;
    float f = clamp(x, 0.0, 1.0) * float(n - 1);
    int i = min(int(f), n - 2);
    return mix(texelFetch(table, ivec2(i, 0), 0).r, texelFetch(table, ivec2(i + 1, 0), 0).r, f - float(i));
}

// Phi at x standard deviations (clamped to the table's [-u_sigmas, u_sigmas])
float cumulative(float x) {
    return table_1d(u_cumulative, x / (2.0 * u_sigmas) + 0.5);
}

#ifdef CLIPPING
// planes and box relative to the volume's centre, as every point here (renderer.py: clip_uniforms)
#include "common/clipping.glsl"
#endif
#ifdef GEOMETRY
uniform sampler2D u_geometry;   // dvr_gl/renderers/surfaces.py: a = the nearest surface's t
#endif

// The ray's part narrowed to the clipped region and to the front of the nearest mesh (pixel: the
// ray's pixel, whose surface ends it).
void narrow_part(vec2 pixel, vec3 o, vec3 d, inout float lo, inout float hi) {
#ifdef CLIPPING
    clip_interval(o, d, lo, hi);
#endif
#ifdef GEOMETRY
    hi = min(hi, texelFetch(u_geometry, ivec2(pixel), 0).a);
#endif
}

// The part of pixel's ray inside the box (from the near plane) and between the view depths `slab`.
bool ray_part(vec2 pixel, vec3 o, vec3 d, vec2 slab, out float lo, out float hi) {
    if (!intersect_box(o, d, u_box_lo, u_box_hi, lo, hi))
        return false;
    lo = max(lo, near_distance(d));
    narrow_part(pixel, o, d, lo, hi);
    float along = dot(d, u_forward);  // the ray's depth per unit length
    lo = max(lo, slab.x / along);
    hi = min(hi, slab.y / along);
    return hi > lo;
}

// The part of this pixel's ray the splat integrates over: the box (from the near plane), clipped,
// before the nearest mesh, and the slab.
bool ray_extent(vec3 o, vec3 d, out float lo, out float hi) {
#ifdef SLABS
    return ray_part(gl_FragCoord.xy, o, d, u_slab, lo, hi);
#else
    if (!intersect_box(o, d, u_box_lo, u_box_hi, lo, hi))
        return false;
    lo = max(lo, near_distance(d));
    narrow_part(gl_FragCoord.xy, o, d, lo, hi);
    return hi > lo;
#endif
}

// The kernel centred at `centre` integrated along the ray over [lo, hi] (world units); 0 if the ray
// misses its support.  spacing: world units per voxel; radius: the support, voxels.  The ray is
// taken from its point at `lo`, near the kernel: measured from the ray's origin, far away, each
// splat's limits would round differently (1e-6 of the distance), an error that scales with the
// value splatted; from a point that every splat of the pixel shares, the rounding is common and
// moves the interval as a whole, an error that scales with the field's gradient.
// closest2: the squared distance (voxels) from the centre to the interval's nearest point.
float kernel_integral(vec3 o, vec3 d, vec3 centre, vec3 spacing, float radius, float lo, float hi,
                      out float closest2) {
    vec3 uo = (o + lo * d - centre) / spacing;
    vec3 ud = d / spacing;
#ifdef LOW_PASS
    vec3 gd = v_metric * ud;                // distances in the widened kernel's metric
    float tv = -dot(uo, ud) / dot(ud, ud);  // the nearest approach in voxels (culling's test)
    vec3 closest = uo + clamp(tv, 0.0, hi - lo) * ud;
#else
    vec3 gd = ud;
#endif
    float a = dot(ud, gd);
    float tc = -dot(uo, gd) / a;            // the ray's nearest approach to the centre, from lo
    vec3 nearest = uo + tc * ud;
#ifdef LOW_PASS
    float q = dot(nearest, v_metric * nearest) / (radius * radius);
#else
    vec3 closest = uo + clamp(tc, 0.0, hi - lo) * ud;
    float q = dot(nearest, nearest) / (radius * radius);
#endif
    closest2 = dot(closest, closest);
    if (q >= 1.0)
        return 0.0;
    float len = sqrt(a);                     // voxels (of the metric) per world unit along the ray
    float half_chord = radius * sqrt(1.0 - q);  // voxels
    float x0 = -tc * len;                    // the interval, voxels from the nearest approach
    float x1 = (hi - lo - tc) * len;
    if (x1 <= -half_chord || x0 >= half_chord)
        return 0.0;
    float share = 1.0;
    if (x0 > -half_chord || x1 < half_chord) {
        // the kernel along the line is a 1D Gaussian (of width u_sigma) cut to the chord
        float c = half_chord / u_sigma;
        float whole = cumulative(c) - cumulative(-c);
        float part = cumulative(min(x1, half_chord) / u_sigma) - cumulative(max(x0, -half_chord) / u_sigma);
        share = whole > 1e-6 ? part / whole : (min(x1, half_chord) - max(x0, -half_chord)) / (2.0 * half_chord);
    }
    float footprint = table_1d(u_footprint, q) / (u_sigma * u_sigma) / len * share;
#ifdef LOW_PASS
    footprint *= v_metric_root;
#endif
    return footprint;
}
