// The ray through this fragment's pixel centre, as dvr_gl.camera.Camera.pixel_rays builds it,
// and (common/box.glsl) its intersection with an axis-aligned box.

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

#include "common/box.glsl"
