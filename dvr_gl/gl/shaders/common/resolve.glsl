    // From the compositing state to the image: emission keeps (colour, optical depth) and needs its
    // opacity; back to front and the isosurface hold the image already; projections classify their
    // value (an empty ray keeps its initial state and stays transparent).
#if defined(COMPOSITE_EMISSION) && defined(XRAY)
    float alpha = opacity_of_depth(state.a);
    frag_color = vec4(state.a > 0.0 ? state.rgb / state.a * alpha : vec3(0.0), alpha);
#elif defined(COMPOSITE_EMISSION) && !defined(BACK_TO_FRONT)
    frag_color = vec4(state.rgb, opacity_of_depth(state.a));
#elif defined(COMPOSITE_EMISSION) || defined(COMPOSITE_ISOSURFACE)
    frag_color = state;
#else
  #if defined(COMPOSITE_AVERAGE)
    bool seen = state.y > 0.0;
    float value = seen ? state.x / state.y : 0.0;
  #elif defined(COMPOSITE_MIP)
    bool seen = state.x > -3.0e38;
    float value = state.x;
  #else
    bool seen = state.x < 3.0e38;
    float value = state.x;
  #endif
  #if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    value = state.z;  // the extremum refined between the samples (the ray caster's projection.glsl)
  #endif
    vec4 tf = transfer_function(value);
    float alpha = seen ? opacity_of_depth(tf.a * u_unit_distance) : 0.0;
    frag_color = vec4(tf.rgb * alpha, alpha);
#endif
