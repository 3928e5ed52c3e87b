// The gradient of the scalar field for shading and gradient-magnitude opacity: central
// differences one voxel apart along each axis (world units), or (GRADIENT_TEXTURE) the
// precomputed gradients at the voxels, reconstructed with the same filter.  Needs
// sample_scalar_voxel() and voxel_coord() from the sampling snippet included before.

#ifdef NEEDS_GRADIENT
  #ifdef GRADIENT_TEXTURE
uniform sampler3D u_gradient;   // central differences at the voxels (world units), same filter
vec3 gradient(vec3 p) {
    return sample_texture(u_gradient, voxel_coord(p)).xyz;
}
  #else
// Central differences one voxel apart along each axis (world units).
vec3 gradient(vec3 p) {
    vec3 u = voxel_coord(p);
    return vec3(sample_scalar_voxel(u + vec3(1, 0, 0)) - sample_scalar_voxel(u - vec3(1, 0, 0)),
                sample_scalar_voxel(u + vec3(0, 1, 0)) - sample_scalar_voxel(u - vec3(0, 1, 0)),
                sample_scalar_voxel(u + vec3(0, 0, 1)) - sample_scalar_voxel(u - vec3(0, 0, 1)))
           / (2.0 * u_voxel_spacing);
}
  #endif
#endif
