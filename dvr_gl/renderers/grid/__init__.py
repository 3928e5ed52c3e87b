"""What the GL renderers of regular grids share: textures (:mod:`.textures`), bricking
(:mod:`.bricking`), the GL base with its caches and uniforms (:mod:`.gl_base`), and the
slicers' common drawing (:mod:`.slicing`).  Only grids have these; other data kinds bring
their own."""
