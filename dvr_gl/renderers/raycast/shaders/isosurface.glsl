// The first isosurface crossing, shaded (raycast.frag's mode parts; the interface is described there).
// The first point with value >= iso among the entry point and the samples, refined by bisection
// between it and the point looked at before.  (ta, sa) is the last point looked at; where it is
// not the sample just before segment k (after a gap: a jump, or in a brick's first sample), a hit
// re-reads it, so the bisection bracket is always the same.  BRICKED: a pass looks at the points
// its brick owns, the bracket's start in its ghost voxels.  State: the shaded hit, alpha 1, once found.

float ta, sa;   // below iso
float tb, sb;   // at or above iso, once found
bool found;
bool previous_known;  // (ta, sa) is the point just before the next sample

const vec4 EMPTY_STATE = vec4(0.0);

bool mode_init(vec4 state) {
    ta = t0;
    sa = 0.0;
    tb = t0;
    sb = 0.0;
    found = false;
    previous_known = false;
#ifdef BRICKED
    if (state.a != 0.0) return true;  // an earlier pass found the surface
    // The entry point belongs to the first window of segments only: a later window's bracket starts at
    // the sample before its first one (re-read on a hit), as one pass's would.
    if (u_segment_window.x == 0 && owns_entry(o + t0 * d)) {
#endif
        sa = sample_scalar(o + t0 * d);
        sb = sa;
        found = sa >= u_iso_value;
        previous_known = true;
#ifdef BRICKED
    }
#endif
    return found;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
    float s = sample_scalar(p);
    if (s >= u_iso_value) {
        tb = t;
        sb = s;
        found = true;
        if (!previous_known) {
            ta = k > 0 ? sample_t(k - 1) : t0;
            sa = sample_scalar(o + ta * d);
        }
    } else {
        ta = t;
        sa = s;
        previous_known = true;
    }
    return found;
}

void mode_gap() {
    previous_known = false;
}

void mode_run(int k) {
}

bool mode_skippable(vec4 block) {
    return block.y < u_iso_value;  // no value in the block reaches iso
}

// Runs: the key is the least block maximum around: reaching iso, no block there can be skipped.
bool mode_dense(float key) {
    return key >= u_iso_value;
}

bool mode_jump(vec4 block, inout int m) {
    return false;
}

vec4 mode_finish(vec4 state) {
    if (!found) return state;
    for (int i = 0; i < u_iso_steps; ++i) {  // bisection keeps s(ta) < iso <= s(tb)
        float tm = 0.5 * (ta + tb);
        float sm = sample_scalar(o + tm * d);
        if (sm >= u_iso_value) { tb = tm; sb = sm; } else { ta = tm; sa = sm; }
    }
    float w = sb > sa ? clamp((u_iso_value - sa) / (sb - sa), 0.0, 1.0) : 1.0;
#ifdef DEPTH
    depth_t = ta + w * (tb - ta);
#endif
    vec3 p = o + (ta + w * (tb - ta)) * d;
    vec3 colour = transfer_function(u_iso_value).rgb;
#ifdef SHADING
    colour = blinn_phong(colour, gradient(p), d);
#endif
    return vec4(colour, 1.0);
}
