"""What every GL renderer stands on, below the renderers and naming none of them.

* :mod:`.context`: the one OpenGL context factory (headless EGL, or a window's), and making a context current;
* :mod:`.shaders`: GLSL found in a renderer's own roots and then the common library (``shaders/``),
  specialized with defines, compiled once per context;
* :mod:`.frame`: the frame kit, :class:`~.frame.GLFrame`: cached resources, render targets, read-back,
  binding, release (every GL renderer is one: :class:`dvr_gl.renderers.base.GLRenderer`);
* :mod:`.geometry`: camera matrices and proxy geometry; :mod:`.lights`: the shading uniforms;
* :mod:`.scattering`: single scattering's defines and uniforms, and the light volume's pass;
* :mod:`.selftest`: a render-and-read-back check of this path (``dvr info``).
"""
