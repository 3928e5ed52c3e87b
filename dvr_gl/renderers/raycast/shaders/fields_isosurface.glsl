// Several fields' isosurface (raycast.frag's mode parts; the interface is described there): the first point,
// among the entry point and the samples, where any member inside its box reaches its own iso-value
// (v_i >= iso_i; ties: the member listed first), refined by bisection on that member alone between it and
// the point looked at before; coloured by that member's transfer function at its iso-value, shaded by its
// own gradient, opaque.  A label member's level is its visibility (1 where its label is listed with some
// opacity, else 0) at one half (its u_field_iso), coloured by the label on the hit's visible side, shaded by
// its indicator; an rgb member's a level of its x, coloured by the data there.  Never bricked: the state is
// the finished pixel (mode_finish).

uniform float u_field_iso[NUM_FIELDS];

float ta, tb;                 // the bracket: the point before, the hit
float before[NUM_FIELDS];     // every member's value at ta
float sb;                     // the hit member's value at tb
int member;                   // the member hit, -1 before
bool found;

const vec4 EMPTY_STATE = vec4(0.0);

// Member i's value at p whose level is its isosurface (a label member's: its visibility).
float field_level(int i, vec3 p, FieldTexels s) {
#ifdef FIELD_LABELS
    if (FIELD_ROLE[i] == 1) return field_label_visible(i, p);
#endif
    return field_value_at(i, s);
}

// Member I's value into values[I], and I the hit if none before it is (the members written out: FIELD_EACH,
// common/fields.glsl).
#define FIELD_REACHING(I) \
    values[I] = field_level(I, p, s); \
    if (hit < 0 && field_inside(I, s) && values[I] >= u_field_iso[I]) hit = I;

// The first member inside its box at or above its iso-value at p (-1: none); every value into `values`.
int first_reaching(vec3 p, out float values[NUM_FIELDS]) {
    FieldTexels s = field_texels(p);
    int hit = -1;
    FIELD_EACH(FIELD_REACHING)
    return hit;
}

bool mode_init(vec4 state) {
    ta = t0;
    tb = t0;
    float values[NUM_FIELDS];
    member = first_reaching(o + t0 * d, values);
    before = values;
    found = member >= 0;
    if (found) sb = values[member];
    return found;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
    float values[NUM_FIELDS];
    member = first_reaching(p, values);
    if (member >= 0) {
        tb = t;
        sb = values[member];
        found = true;
    } else {
        ta = t;
        before = values;
    }
    return found;
}

void mode_gap() {
}

void mode_run(int k) {
}

bool mode_skippable(vec4 block) {
    return false;
}

bool mode_dense(float key) {
    return true;
}

bool mode_jump(vec4 block, inout int m) {
    return false;
}

// Member i's value at world point p alone (a label member's visibility).
float member_value(int i, vec3 p) {
#ifdef FIELD_LABELS
    if (FIELD_ROLE[i] == 1) return field_label_visible(i, p);
#endif
    return field_value(i, field_group_texels(FIELD_GROUP[i], p));
}

vec4 mode_finish(vec4 state) {
    if (!found) return state;
    float iso = u_field_iso[member];
    float sa = before[member];
    for (int i = 0; i < u_iso_steps; ++i) {  // bisection keeps s(ta) < iso <= s(tb), on the member hit
        float tm = 0.5 * (ta + tb);
        float sm = member_value(member, o + tm * d);
        if (sm >= iso) { tb = tm; sb = sm; } else { ta = tm; sa = sm; }
    }
    float w = sb > sa ? clamp((iso - sa) / (sb - sa), 0.0, 1.0) : 1.0;
    vec3 p = o + (ta + w * (tb - ta)) * d;
#ifdef FIELD_LABELS
    if (FIELD_ROLE[member] == 1) return vec4(field_label_classify(member, o + tb * d, d).rgb, 1.0);
#endif
    vec3 colour = field_transfer_function(member, iso).rgb;
#ifdef FIELD_RGB
    if (FIELD_ROLE[member] == 2) colour = max(field_group_texels(FIELD_GROUP[member], p).rgb, 0.0);
#endif
#ifdef SHADING
    colour = blinn_phong(colour, field_gradient_at(member, p) * u_field_epsilon_scale[member], d);
#endif
    return vec4(colour, 1.0);
}
