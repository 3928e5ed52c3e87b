// Several fields' per-channel projections: COMPOSITE_AVERAGE, COMPOSITE_MIP, COMPOSITE_MINIP (raycast.frag's
// mode parts; the interface is described there).  Each member's own projection over its samples inside its
// box, classified by its own transfer function with the opacity of one unit_distance (a_i, c_i); the pixel:
// premultiplied colour sum_i a_i c_i (additive, the classic multichannel MIP), alpha 1 - prod_i (1 - a_i).
// Never bricked: the state is the finished pixel (mode_finish).

float value[NUM_FIELDS];   // each member's running sum, maximum or minimum
float total[NUM_FIELDS];   // each member's length summed inside its box (every mode: > 0 once seen)

const vec4 EMPTY_STATE = vec4(0.0);

bool mode_init(vec4 state) {
    for (int i = 0; i < NUM_FIELDS; ++i) {
#if defined(COMPOSITE_MIP)
        value[i] = -3.0e38;
#elif defined(COMPOSITE_MINIP)
        value[i] = 3.0e38;
#else
        value[i] = 0.0;
#endif
        total[i] = 0.0;
    }
    return false;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
    FieldTexels s = field_texels(p);
    for (int i = 0; i < NUM_FIELDS; ++i) {
        if (!field_inside(i, s)) continue;
        float v = field_value_at(i, s);
#if defined(COMPOSITE_AVERAGE)
        value[i] += v * len;
#elif defined(COMPOSITE_MIP)
        value[i] = max(value[i], v);
#else
        value[i] = min(value[i], v);
#endif
        total[i] += len;
    }
    return false;
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

vec4 mode_finish(vec4 state) {
    vec3 colour = vec3(0.0);
    float clear = 1.0;  // prod_i (1 - a_i)
    for (int i = 0; i < NUM_FIELDS; ++i) {
        if (total[i] <= 0.0) continue;  // no sample inside its box: transparent
#if defined(COMPOSITE_AVERAGE)
        float v = value[i] / total[i];
#else
        float v = value[i];
#endif
        vec4 tf = field_transfer_function(i, v);
        float alpha = opacity_of_depth(tf.a * u_field_unit_distance[i]);
        colour += alpha * tf.rgb;
        clear *= 1.0 - alpha;
    }
    return vec4(colour, 1.0 - clear);
}
