// Stage 1 of raycast.frag: the ray and its segments.  Distances t are world units along the unit
// direction d from the origin o (the camera's: common/camera_ray.glsl), as dvr_gl.rays and the
// reference (dvr_gl.reference.discrete) measure them.

uniform vec3 u_box_lo;
uniform vec3 u_box_hi;
uniform float u_sample_distance;     // world units: the length of every segment but the last
#ifdef GEOMETRY
uniform sampler2D u_geometry;  // dvr_gl/renderers/surfaces.py: a = the nearest surface's t (3e38: none)
#endif

// The ray, set by set_up_ray() (and `offset` by main) before any other stage runs; the mode parts
// read them too.  Points o + t d; the kept part [t0, t1] in n segments of u_sample_distance (the
// last shortened to end at t1), each sampled at `offset` (0.5, or jittered: [0, 1)) of its length.
vec3 o, d;
float t0, t1, offset;
int n;

// Segment k of the ray: [start, start + len], sampled at t = start + offset len (world units along d).
// The one place the segments are laid out: every stage and mode part that needs one asks for it here.
struct Segment {
    float start;
    float len;
    float t;
};

Segment segment(int k) {
    Segment s;
    s.start = t0 + float(k) * u_sample_distance;
    s.len = min(u_sample_distance, t1 - s.start);
    s.t = s.start + offset * s.len;
    return s;
}

// Parameter of the sample of segment k.
float sample_t(int k) {
    return segment(k).t;
}

// `offset`: the place of each segment's sample within it, as a fraction of its length: the middle, or (JITTER)
// this pixel's offset (common/jitter.glsl, as dvr_gl.rays.jitter_offsets).
float sample_offset() {
#ifdef JITTER
    return jitter_offset();
#else
    return 0.5;
#endif
}

// Set up the ray through this pixel: reads the camera, the box [u_box_lo, u_box_hi] (world), the
// clipping region (CLIPPING), the opaque surfaces' depth (GEOMETRY) and the near plane; writes o, d,
// t0, t1 and n (at least 1, from the ray's length: no loop cap here).  Returns whether the ray meets
// the box at all (t1 > t0 is left to the caller: clipping may empty a ray that meets it).
bool set_up_ray() {
    camera_ray(o, d);
    bool hit = intersect_box(o, d, u_box_lo, u_box_hi, t0, t1);
#ifdef CLIPPING
    clip_interval(o, d, t0, t1);  // the kept part of the ray, sampled as the box's is
#endif
#ifdef GEOMETRY
    t1 = min(t1, texelFetch(u_geometry, ivec2(gl_FragCoord.xy), 0).a);  // ends at an opaque surface
#endif
    t0 = max(t0, near_distance(d));
    n = max(int(ceil((t1 - t0) / u_sample_distance)), 1);
    return hit;
}
