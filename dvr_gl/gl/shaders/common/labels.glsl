// Label maps sampled without inventing a label: dvr_gl/labels/sampling.py's float64 rule on the GPU
// (docs/labels.md).  The 8 voxels around p (taps clamped to the edge, as the linear filter's) give each
// of their labels L its indicator I_L = the sum of the trilinear weights of the taps labelled L; the
// sample's label is argmax_L I_L, ties to the smaller label, so a label no tap holds never appears (3 beside
// 5 never reads 4).  FILTER_NEAREST: the nearest voxel's label.  Either way the gradient returned is that
// of the chosen label's trilinear indicator, per world unit (it points into the label: shade with minus it).
//
// Interface: every function takes what it reads as arguments, so that any pass can sample any member.
//   LabelGrid g = label_grid(channel, value_scale, value_offset, dims, world_to_voxel_scale,
//                            world_to_voxel_offset);
//       channel: the texture component holding this member (0..3: members on one grid share a texture);
//       label = round(texel * value_scale + value_offset) (the upload's unorm or float precision, as
//       dvr_gl/renderers/grid/textures.py writes it); dims: voxels along x, y, z; voxel coordinate
//       u = p * world_to_voxel_scale + world_to_voxel_offset (voxel i at u = i; p in world units).
//   int label_sample(sampler3D tex, LabelGrid g, vec3 p, out vec3 gradient): by the filter's define;
//   int label_linear(...) and int label_nearest(...) (same arguments): either rule whatever the define;
//   vec4 label_class(sampler2D table, ivec3 table_layout, int label): (linear r, g, b, sigma per world unit) of a
//       label from LabelTable's GPU table (dvr_gl/labels/table.py: table_layout = (first label, texel count,
//       texels per row)); zero (transparent) for a label the table does not list.

struct LabelGrid {
    int channel;
    float value_scale;
    float value_offset;
    ivec3 dims;
    vec3 scale;
    vec3 offset;
};

LabelGrid label_grid(int channel, float value_scale, float value_offset, ivec3 dims, vec3 scale, vec3 offset) {
    return LabelGrid(channel, value_scale, value_offset, dims, scale, offset);
}

// The label of voxel i (clamped to the grid); labels are whole numbers, so rounding the texel's value
// is exact for every format the upload uses.
int label_at(sampler3D tex, LabelGrid g, ivec3 i) {
    vec4 t = texelFetch(tex, clamp(i, ivec3(0), g.dims - 1), 0);
    return int(floor(t[g.channel] * g.value_scale + g.value_offset + 0.5));
}

// The 8 taps around p, x fastest: their labels, and the lowest tap's voxel i0 and fraction f (taps clamped
// to the edge, as the linear filter's).  The weights come after (label_weights), only where the taps differ:
// where they agree (most samples) none is needed (a few % of a frame; docs/labels.md, "Cost").
void label_fetch(sampler3D tex, LabelGrid g, vec3 p, out int labels[8], out vec3 u, out vec3 f) {
    u = p * g.scale + g.offset;
    vec3 uc = clamp(u, vec3(0.0), vec3(g.dims - 1));
    ivec3 i0 = clamp(ivec3(floor(uc)), ivec3(0), max(g.dims - 2, ivec3(0)));
    f = uc - vec3(i0);
    for (int j = 0; j < 8; ++j)
        labels[j] = label_at(tex, g, min(i0 + ivec3(j & 1, (j >> 1) & 1, j >> 2), g.dims - 1));
}

// The taps' trilinear weights and the weights' gradients per world unit (zero along an axis where u lies
// outside [0, n - 1], where the clamp holds the weights constant).
void label_weights(LabelGrid g, vec3 u, vec3 f, out float w[8], out vec3 dw[8]) {
    vec3 du = vec3(greaterThanEqual(u, vec3(0.0))) * vec3(lessThanEqual(u, vec3(g.dims - 1))) * g.scale;
    for (int j = 0; j < 8; ++j) {
        vec3 o = vec3(j & 1, (j >> 1) & 1, j >> 2);
        vec3 wa = mix(1.0 - f, f, o);
        vec3 da = mix(-du, du, o);
        w[j] = wa.x * wa.y * wa.z;
        dw[j] = vec3(da.x * wa.y * wa.z, wa.x * da.y * wa.z, wa.x * wa.y * da.z);
    }
}

// Whether the 8 taps hold one label (inside a region: most samples): that label, no gradient.
bool label_uniform(int labels[8]) {
    bool same = true;
    for (int k = 1; k < 8; ++k)
        same = same && labels[k] == labels[0];
    return same;
}

vec3 label_indicator_gradient(int labels[8], vec3 dw[8], int label) {
    vec3 sum = vec3(0.0);
    if (label_uniform(labels))
        return sum;
    for (int k = 0; k < 8; ++k)
        sum += labels[k] == label ? dw[k] : vec3(0.0);
    return sum;
}

int label_linear(sampler3D tex, LabelGrid g, vec3 p, out vec3 gradient) {
    int labels[8];
    vec3 u, f;
    label_fetch(tex, g, p, labels, u, f);
    if (label_uniform(labels)) {
        gradient = vec3(0.0);
        return labels[0];
    }
    float w[8];
    vec3 dw[8];
    label_weights(g, u, f, w, dw);
    int best_label = labels[0];
    float best = -1.0;
    for (int j = 0; j < 8; ++j) {
        float indicator = 0.0;
        for (int k = 0; k < 8; ++k)
            indicator += labels[k] == labels[j] ? w[k] : 0.0;
        if (indicator > best || (indicator == best && labels[j] < best_label)) {
            best = indicator;
            best_label = labels[j];
        }
    }
    gradient = label_indicator_gradient(labels, dw, best_label);
    return best_label;
}

int label_nearest(sampler3D tex, LabelGrid g, vec3 p, out vec3 gradient) {
    int labels[8];
    vec3 u, f;
    label_fetch(tex, g, p, labels, u, f);
    int label = label_at(tex, g, ivec3(floor(p * g.scale + g.offset + 0.5)));
    if (label_uniform(labels)) {
        gradient = vec3(0.0);
        return label;
    }
    float w[8];
    vec3 dw[8];
    label_weights(g, u, f, w, dw);
    gradient = label_indicator_gradient(labels, dw, label);
    return label;
}

int label_sample(sampler3D tex, LabelGrid g, vec3 p, out vec3 gradient) {
#ifdef FILTER_NEAREST
    return label_nearest(tex, g, p, gradient);
#else
    return label_linear(tex, g, p, gradient);
#endif
}

vec4 label_class(sampler2D table, ivec3 table_layout, int label) {
    int k = label - table_layout.x;
    if (k < 0 || k >= table_layout.y)
        return vec4(0.0);
    return texelFetch(table, ivec2(k % table_layout.z, k / table_layout.z), 0);
}
