// The ray through this fragment's pixel centre, as dvr_gl.camera.Camera.pixel_rays builds it,
// and its intersection with an axis-aligned box (slab method, as dvr_gl.rays.intersect_box).

uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_right;
uniform vec3 u_up;
// perspective: (tan(fov/2) * aspect, tan(fov/2)); orthographic: half the view width and height
uniform vec2 u_half_extent;
uniform vec2 u_image_size;
uniform float u_near;

// The ray through the pixel whose centre is at window coordinates `frag` (as gl_FragCoord.xy).
void camera_ray_at(vec2 frag, out vec3 origin, out vec3 dir) {
    // gl_FragCoord.y counts from the bottom: ndc.y = 1 - 2 (row + 0.5) / H for row from the top
    vec2 ndc = frag / u_image_size * 2.0 - 1.0;
#ifdef CAMERA_ORTHOGRAPHIC
    origin = u_eye + ndc.x * u_half_extent.x * u_right + ndc.y * u_half_extent.y * u_up;
    dir = u_forward;
#else
    origin = u_eye;
    dir = normalize(u_forward + ndc.x * u_half_extent.x * u_right + ndc.y * u_half_extent.y * u_up);
#endif
}

void camera_ray(out vec3 origin, out vec3 dir) {
    camera_ray_at(gl_FragCoord.xy, origin, dir);
}

float near_distance(vec3 dir) {
#ifdef CAMERA_ORTHOGRAPHIC
    return u_near;
#else
    return u_near / dot(dir, u_forward);
#endif
}

// Entry and exit parameters of the closed box [lo, hi]; false when the ray misses it.
// A ray parallel to a slab is inside it for all t when its origin lies in the closed slab.
// Branchless (a per-axis loop with branches costs llvmpipe 6 % of a whole frame): the
// parallel axes' values, inf or NaN from dividing by zero, are replaced by selection.
bool intersect_box(vec3 o, vec3 d, vec3 lo, vec3 hi, out float t_enter, out float t_exit) {
    bvec3 parallel = equal(d, vec3(0.0));
    vec3 inv = 1.0 / mix(d, vec3(1.0), parallel);
    vec3 ta = (lo - o) * inv;
    vec3 tb = (hi - o) * inv;
    vec3 tmin = mix(min(ta, tb), vec3(-3.0e38), parallel);
    vec3 tmax = mix(max(ta, tb), vec3(3.0e38), parallel);
    t_enter = max(max(tmin.x, tmin.y), tmin.z);
    t_exit = min(min(tmax.x, tmax.y), tmax.z);
    bvec3 outside = bvec3(ivec3(lessThan(o, lo)) | ivec3(greaterThan(o, hi)));
    return !any(bvec3(ivec3(parallel) & ivec3(outside)));
}
