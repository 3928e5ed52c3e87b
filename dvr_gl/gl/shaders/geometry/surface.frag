#version 330 core
// The nearest surface per pixel (the depth test keeps it): rgb its Blinn-Phong shaded colour with
// [renderer.shading]'s lights (SHADING; else the colour as it is), the face normal turned toward
// the eye; a its distance t along the pixel's ray (the ray casters end their rays there), as
// dvr_gl.geometry.surface_rgba finds them in float64.
#include "common/shading.glsl"

uniform vec3 u_eye;
uniform vec3 u_forward;
in vec3 world;
flat in vec3 face_normal;
flat in vec3 face_colour;
out vec4 frag_color;

void main() {
#ifdef CAMERA_ORTHOGRAPHIC
    vec3 dir = u_forward;
    float t = dot(world - u_eye, u_forward);
#else
    vec3 dir = normalize(world - u_eye);
    float t = length(world - u_eye);
#endif
    vec3 n = dot(face_normal, dir) > 0.0 ? -face_normal : face_normal;
#ifdef SHADING
    vec3 rgb = blinn_phong(face_colour, -n, dir);  // blinn_phong takes the gradient: -normal
#else
    vec3 rgb = face_colour;
#endif
    frag_color = vec4(rgb, t);
}
