"""The grid sampling kit: what the GL renderers that sample a regular voxel grid share, and only they.

* :mod:`.sampling`: :class:`~.sampling.GridRenderer`, their base (a GL renderer, :mod:`dvr_gl.gl.frame`,
  drawing passes over grid views with their textures, tables and light volume);
* :mod:`.views`: grid views (the whole volume, a brick, a brick of a coarser level) and their uniforms;
* :mod:`.bricking`: bricks that fit a texture, their ghosts and visibility order;
* :mod:`.textures`: volumes, fields and tables uploaded in the volume's own precision;
* :mod:`.lru`: the texture budget's least-recently-used cache of bricks read apart;
* :mod:`.tables`: the transfer function's lookup and pre-integration tables as textures;
* :mod:`.classification`: the defines and uniforms of ``classify()``: filtering, classification, shading;
* :mod:`.slicing`: the slicers' common drawing (proxy slices blended back to front).

Other data kinds bring their own kits (:mod:`dvr_gl.renderers.mesh`); what every GL renderer shares
is the frame kit, :mod:`dvr_gl.gl.frame`.
"""
