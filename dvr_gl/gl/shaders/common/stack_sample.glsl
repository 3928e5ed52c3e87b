// Sampling a stack of 2D slices (a texture array, layer = voxel index across the stack's axis),
// bilinear within a slice as 2D texture slicing does.  A sample on a slice (or one voxel off it
// across the stack, for central differences, or on the next slice, for pre-integration) takes
// the nearest layer; within the layer it interpolates as the trilinear reference does on a
// voxel plane.  Provides voxel_coord(), sample_scalar_voxel(), sample_scalar().

uniform vec3 u_world_to_voxel_scale;    // u = p * scale + offset
uniform vec3 u_world_to_voxel_offset;
uniform vec3 u_voxel_spacing;
uniform ivec3 u_dims;                   // the sampled grid (x, y, z)
uniform sampler2DArray u_stack;
uniform ivec3 u_axes;                   // voxel axes of the stack's columns, rows and layers
uniform float u_value_scale;            // data value = texel * scale + offset
uniform float u_value_offset;

vec3 voxel_coord(vec3 p) {
    return p * u_world_to_voxel_scale + u_world_to_voxel_offset;
}

float stack_texel(ivec2 ij, int layer) {
    ivec2 size = ivec2(u_dims[u_axes.x], u_dims[u_axes.y]);
    return texelFetch(u_stack, ivec3(clamp(ij, ivec2(0), size - 1), layer), 0).r;
}

float sample_scalar_voxel(vec3 u) {
    int layer = int(clamp(floor(u[u_axes.z] + 0.5), 0.0, float(u_dims[u_axes.z] - 1)));
    vec2 uv = vec2(u[u_axes.x], u[u_axes.y]);
    vec2 size = vec2(u_dims[u_axes.x], u_dims[u_axes.y]);
#if defined(FILTER_NEAREST)
    float texel = stack_texel(ivec2(floor(uv + 0.5)), layer);
#elif defined(FILTER_IN_SHADER)
    vec2 uc = clamp(uv, vec2(0.0), size - 1.0);
    ivec2 i0 = clamp(ivec2(floor(uc)), ivec2(0), max(ivec2(size) - 2, ivec2(0)));
    vec2 f = uc - vec2(i0);
    float texel = mix(mix(stack_texel(i0, layer), stack_texel(i0 + ivec2(1, 0), layer), f.x),
                      mix(stack_texel(i0 + ivec2(0, 1), layer), stack_texel(i0 + ivec2(1, 1), layer), f.x), f.y);
#else
    vec2 uc = clamp(uv, vec2(0.0), size - 1.0);
    float texel = texture(u_stack, vec3((uc + 0.5) / size, float(layer))).r;
#endif
    return texel * u_value_scale + u_value_offset;
}

float sample_scalar(vec3 p) {
    return sample_scalar_voxel(voxel_coord(p));
}
