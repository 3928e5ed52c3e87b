// Blinn-Phong from the gradient (dvr_gl.shading): normal = -gradient / |gradient|;
// a gradient weaker than u_gradient_epsilon (rounding noise in homogeneous regions) gives a
// zero normal, hence ambient light only; TWO_SIDED flips the normal toward the viewer.
// Light i: xyz = direction toward the light (world), w = 1 for a headlight (toward the eye).

#ifdef SHADING
uniform vec4 u_light_dir[NUM_LIGHTS];
uniform vec3 u_light_color[NUM_LIGHTS];
uniform float u_ambient;
uniform float u_diffuse;
uniform float u_specular;
uniform float u_shininess;
uniform float u_gradient_epsilon;

vec3 blinn_phong(vec3 colour, vec3 grad, vec3 ray_dir) {
    float m = length(grad);
    vec3 n = m > u_gradient_epsilon ? -grad / m : vec3(0.0);
    vec3 v = -ray_dir;
  #ifdef TWO_SIDED
    if (dot(n, v) < 0.0) n = -n;
  #endif
    vec3 diffuse = vec3(0.0);
    vec3 specular = vec3(0.0);
    for (int i = 0; i < NUM_LIGHTS; ++i) {
        vec3 l = u_light_dir[i].w > 0.5 ? v : u_light_dir[i].xyz;
        float ndotl = dot(n, l);
        diffuse += u_light_color[i] * max(ndotl, 0.0);
        vec3 h = l + v;
        float hl = length(h);
        float ndoth = hl > 0.0 ? max(dot(n, h / hl), 0.0) : 0.0;
        // 0^0 = 1, as numpy has it (GLSL leaves pow(0, 0) undefined)
        float spec = u_shininess == 0.0 ? 1.0 : (ndoth > 0.0 ? pow(ndoth, u_shininess) : 0.0);
        if (ndotl > 0.0) specular += u_light_color[i] * spec;
    }
    return colour * (u_ambient + u_diffuse * diffuse) + u_specular * specular;
}
#endif
