"""Projected tetrahedra in GL (see the package doc and ``docs/meshes.md``).

The mesh goes to the GPU once (points relative to its centre, so float32 keeps their precision;
cells; each cell's face planes and scalar as ``g . p + c``, computed in float64), as textures of
4096 texels a row; a frame uploads only the visibility order (a texture: no vertex buffer; each
cell's footprint is drawn by ``pt.geom``, or Shirley-Tuchman's fan built by ``pt_fan.comp`` into a
vertex buffer on the GPU: :attr:`ProjectedTetrahedraRenderer.compute_fan`).
Emission-absorption blends the fragments' premultiplied colours with the over operator, back to
front; MIP and MinIP blend by max and min, the average by addition, and the isosurface keeps the
nearest hit by the depth test: those need no order.  The projections' values are classified on
the host with the exact transfer function, as the converged reference does.
"""

from __future__ import annotations

import time

import moderngl
import numpy as np

from ... import limits
from ...gl.shaders import ShaderError, create_program, load_shader, program_cache, shader_root
from ...sandbox import current
from ..mesh import SHADERS as MESH_SHADERS
from ..mesh.textures import MODES, ROW, MeshRenderer, rows
from .fan import HostFan
from .fan import compiled as compiled_fan
from .order import TILE, VisibilityOrder, reaching, tile_coherent

#: Its own GLSL, then the kit's (before the common library).
SHADERS = (shader_root(__file__), MESH_SHADERS)

COVER_ALL = np.uint32(1 << 31)  # an order entry's flag: the cell reaches behind the eye's plane (pt.vert)
#: Fragment work a pixel costs per cube root of the cells (a ray crosses a few times that many cells,
#: each fragment integrating its piece exactly): measured with the oxygen post (513k cells) at 256^2 to
#: 4096^2, 5e-6 s a pixel against the GL rate of 3e8 samples a second (limits.RATES): 1500 = 19 x 80.
FRAGMENTS_PER_CUBE_ROOT = 20
#: A slot's triangles in the compute fan's rows (thick, h0, h1, h2, h3): pt.geom's strips' triangles,
#: vertex for vertex (h0 h1 thick, thick h1 h2, h2 h3 thick, thick h3 h0).
FAN_INDICES = np.array([1, 2, 0, 0, 2, 3, 3, 4, 0, 0, 4, 1], np.uint32)
BATCHES = 32  # draw calls a frame is cut into, in order, for progress and the time limit between them


class ProjectedTetrahedraRenderer(MeshRenderer):
    name = "projected-tetrahedra"
    description = "projected tetrahedra in GL for meshes, exact visibility order"

    #: ``True``: Shirley-Tuchman's fan built on the host where numba is installed (:mod:`.fan`: no geometry
    #: shader); ``False`` (the default, and without numba): built in ``pt.geom``.  Measured on llvmpipe
    #: (README): the geometry stage it saves costs about what the numba build costs, so not the default.
    host_fan = False
    #: Leave out of an emission-absorption frame's draw the cells whose projected bounding box holds no pixel
    #: centre (:func:`.order.reaching`; they draw no fragment, so the picture is the same): the geometry stage
    #: and the rasterizer's setup are spent on them for nothing.  Measured (README): the blunt fin 9-14 %
    #: faster a frame; the oxygen post leaves out 29-35 % of its cells.
    cull_unreached = True
    #: ``True`` (the default): Shirley-Tuchman's fan built by a compute shader (``pt_fan.comp``, once a frame
    #: after the order, into a vertex buffer drawn in slot order with ``pt_fan.vert``) where the context has
    #: GL 4.3; else (and with ``False``) in ``pt.geom``.  The same picture within float32 rounding; llvmpipe
    #: runs compute shaders on its thread pool, the geometry stage on the calling thread.  Measured (README): 1.04-1.13x
    #: the geometry shader's frame on every comb view in 3 of 5 interleaved runs (0.88-1.07 in the busiest).
    compute_fan = True
    #: Screen tiles (pixels a side) the emission-absorption draw's order is grouped by where it culls unreached
    #: cells with numba installed (:func:`.order.tile_coherent`: the cells touching any one tile keep their
    #: order, so the picture is the same to the bit); 0: the visibility order as it is.  llvmpipe rasterizes
    #: a 64-pixel tile's triangles in the order drawn, and in the visibility order consecutive cells lie far
    #: apart on screen.  Measured (README, ``benchmarks/tile_order.py``): Shirley-Tuchman's draw 11-23 % shorter
    #: on 11 of 12 views of the four large shared meshes, the jaw's frame 1.11-1.24x faster, for 2.5 + 11 ms of
    #: host work there.
    tile_pixels = TILE

    def __init__(self, ctx=None):
        super().__init__(ctx)
        self._count_fragments = False

    def work(self, scene):
        """Pixels times the fragments a pixel's ray meets (:data:`FRAGMENTS_PER_CUBE_ROOT` per cube root
        of the cells), in the GL renderers' unit."""
        cells = len(scene.field.tets)
        per_pixel = FRAGMENTS_PER_CUBE_ROOT * cells ** (1.0 / 3.0)
        img = scene.image
        return limits.Work(float(img.width) * img.height * per_pixel, "gpu samples",
                           f"{img.width}x{img.height} pixels x about {per_pixel:.3g} fragment samples for "
                           f"{cells} cells", "lower --size, or use cell-raycast or --resample")

    def _mesh_extra(self, mesh, textures):
        return VisibilityOrder(mesh)

    # --- a frame ---

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        r, cam, img, mesh = scene.renderer, scene.camera, scene.image, scene.field
        mode = r.compositing
        start = time.perf_counter()
        textures, orders = self._mesh_resources(mesh)
        tf = scene.transfer_function
        defines = {MODES[mode]: True, "CAMERA_ORTHOGRAPHIC": cam.projection == "orthographic"}
        if mode == "emission_absorption":
            defines.update(ALPHA_MODEL=tf.opacity_model == "alpha", TF_COUNT=len(tf.points),
                           TF_POW2=1 << len(tf.points).bit_length())
        if self._count_fragments:
            defines = {"FRAGMENT_COUNT": True, "CAMERA_ORTHOGRAPHIC": defines["CAMERA_ORTHOGRAPHIC"]}
        defines.update(self._kept_part_defines(scene, surfaces))
        interpolated = self._shirley_tuchman(scene, defines)
        host = self._host_fan(scene, textures) if interpolated else None
        if host is not None:  # the fan's vertices built in a thread while the order is computed here
            host.start(scene, self.view_projection(scene, textures.centre), textures.visible(tf))
        if mode == "emission_absorption":
            gaps = self._gap_pixels(scene, textures, orders) if r.cell_order == "exact" else None
            order, stats = orders(cam, img.width, img.height, r.cell_order, pixels=gaps)
            # transparent cells, and cells that reach no pixel centre, are ordered (the relations run through
            # them) but not drawn
            drawn_cells, tiles = textures.visible(scene.transfer_function), None
            if self.cull_unreached:
                reached, tiles = self._reaching(scene, textures, orders, self.tile_pixels)
                drawn_cells = drawn_cells & reached
            order = order[drawn_cells[order]][::-1]  # drawn back to front
            if tiles is not None:  # grouped by screen tile, the order kept in every tile: the same picture
                size = self.tile_pixels
                order = tile_coherent(order, tiles, -(-img.width // size), -(-img.height // size), orders.fast)
            stats["tiles"] = self.tile_pixels if tiles is not None else 0
            stats["order_seconds"] = time.perf_counter() - start  # with the boundary's count in GL
        else:
            order, stats = np.arange(textures.cells), {"order": "none (blended)", "order_seconds": 0.0}
        drawn = time.perf_counter()
        stats["integration"] = "shirley-tuchman" if interpolated else "exact"
        if interpolated:
            stats["fan"] = "host" if host is not None else "geometry shader"
        defines["SHIRLEY_TUCHMAN"] = interpolated
        slots = None
        if host is not None:  # the fan built on the host, in a vertex buffer (fan.py): no geometry shader
            program = create_program(self.ctx, "pt_fan.vert", "pt_st.frag", roots=SHADERS)
            host.finish(order)
            self._uniforms(program, scene, textures)
            vao = self.ctx.vertex_array(program, [(host.vertices, "2f 4f 1f", "in_pixel", "in_st", "in_tau_max")],
                                        index_buffer=host.indices, index_element_size=4)
            primitive, per_cell = moderngl.TRIANGLES, host.fast.CELL_INDICES  # four triangles a cell
        elif interpolated and self._has_compute():  # the fan built by a compute shader, drawn as the host's
            program = create_program(self.ctx, "pt_fan.vert", "pt_st.frag", roots=SHADERS)
            slots = self._order_texture(order)
            fan, indices = self._compute_fan(scene, textures, defines, slots, len(order))
            self._uniforms(program, scene, textures)
            vao = self.ctx.vertex_array(program, [(fan, "2f 4f 1f 4x", "in_pixel", "in_st", "in_tau_max")],
                                        index_buffer=indices, index_element_size=4)
            primitive, per_cell = moderngl.TRIANGLES, len(FAN_INDICES)
            stats["fan"] = "compute shader"
        else:  # one point a cell, its footprint built in pt.geom
            program = create_program(self.ctx, "pt.vert", "pt_st.frag" if interpolated else "pt.frag", defines,
                                     geometry="pt.geom", roots=SHADERS)
            self._uniforms(program, scene, textures)
            slots = self._order_texture(self._flag_cover_all(order, scene))
            self.bind(program, {}, {**dict(textures.textures), "u_order": slots, **surfaces})
            vao = self.ctx.vertex_array(program, [])
            primitive, per_cell = moderngl.POINTS, 1
        _, fbo = self.target("image", img.width, img.height, depth=True)  # the isosurface's nearest hit
        fbo.use()
        fbo.viewport = (0, 0, img.width, img.height)
        clear = {"mip": (-3.0e38, 0.0), "minip": (3.0e38, 0.0)}.get(mode, (0.0, 0.0))
        fbo.clear(clear[0], clear[1], 0.0, 0.0, depth=1.0)
        self._blending(mode)
        try:
            # one draw, unless someone watches the progress or a time limit must be checked between draws
            watched = self.progress is not None or current().max_seconds is not None
            step = max(-(-len(order) // (BATCHES if watched else 1)), 1)
            for first in range(0, len(order), step):  # in order: GL draws the calls one after another
                vao.render(primitive, vertices=per_cell * min(step, len(order) - first), first=per_cell * first)
                self.ctx.finish()
                self.report(min(first + step, len(order)), len(order))
            image = self.read(fbo, img.width, img.height)  # float32, a fresh array
        finally:
            vao.release()
            if slots is not None:
                slots.release()
            self._blending(None)
        now = time.perf_counter()
        self.stats = {**stats, "draw_seconds": now - drawn, "seconds": now - start, "cells": textures.cells,
                      "cells_drawn": len(order),
                      "cells_per_second": textures.cells / max(now - start, 1e-12)}
        if mode == "emission_absorption" or self._count_fragments:
            return image
        return self._resolve(scene, image.astype(np.float64)).astype(np.float32)

    def _has_compute(self) -> bool:
        """Whether this frame's fan is built by ``pt_fan.comp``: :attr:`compute_fan` and GL 4.3."""
        return self.compute_fan and self.ctx.version_code >= 430

    def _compute_fan(self, scene, textures, defines, slots, count):
        """Build the fan of the ``count`` cells in ``slots`` (the order texture) with ``pt_fan.comp`` into a
        vertex buffer (5 rows of 8 floats a slot, the last padding, kept per mesh), and the fixed index buffer
        that draws slot after slot."""
        cells = textures.cells
        fan = self._cached("compute fan", (scene.field,), lambda: self.ctx.buffer(reserve=max(5 * 8 * 4 * cells, 4)))
        indices = self._cached("compute fan indices", (scene.field,), lambda: self.ctx.buffer(
            (FAN_INDICES[None, :] + 5 * np.arange(cells, dtype=np.uint32)[:, None]).astype(np.uint32).tobytes()))
        keys = {k: defines[k] for k in ("CAMERA_ORTHOGRAPHIC", "ALPHA_MODEL", "TF_COUNT", "TF_POW2", "EMISSION")
                if k in defines}
        comp = self._compute_program("pt_fan.comp", {**keys, "SHIRLEY_TUCHMAN": True})
        self._uniforms(comp, scene, textures)
        self.bind(comp, {"u_slots": count}, {**dict(textures.textures), "u_order": slots})
        fan.bind_to_storage_buffer(0)
        groups = max(-(-count // 64), 1)
        gx = min(groups, 65535)
        comp.run(gx, -(-groups // gx), 1)
        self.ctx.memory_barrier()
        return fan, indices

    def _compute_program(self, name: str, defines: dict):
        """The compute shader ``name`` with ``defines``, compiled once per context (kept with its programs,
        :func:`.program_cache`, so released with them)."""
        cache = program_cache(self.ctx)
        key = ("compute", name, SHADERS, tuple(sorted(defines.items())))
        if key not in cache:
            source = load_shader(name, defines, SHADERS)
            try:
                cache[key] = self.ctx.compute_shader(source.text)
            except moderngl.Error as exc:
                raise ShaderError(f"GLSL compile failed in {name}: {' '.join(str(exc).split())[:300]} (renderer "
                                  f"{self.ctx.info['GL_RENDERER']}); set compute_fan = False to build the fan "
                                  f"in pt.geom") from exc
        return cache[key]

    def _reaching(self, scene, textures, orders, tile: int = 0):
        """``(reached, tiles)``: which cells reach a pixel centre (:func:`.order.reaching`, compiled where the
        order is), and with ``tile > 0`` and the compiled order each cell's range of ``tile``-pixel screen
        tiles (else ``None``); every cell and ``None`` where the mesh reaches the eye's plane (a vertex there
        has no projection)."""
        mesh, img = scene.field, scene.image
        if self._reaches_near_plane(scene):
            return np.ones(len(mesh.tets), bool), None
        points, tets = self._cached("centred mesh", (mesh,), lambda: (
            np.ascontiguousarray(mesh.points - textures.centre, dtype=np.float64),
            np.ascontiguousarray(mesh.tets, dtype=np.int64)))
        if orders.fast is None or max(img.width, img.height) > 256 * tile:  # a byte a tile's column or row
            tile = 0
        tiles = np.empty(len(tets), np.uint32) if tile > 0 else None
        reached = reaching(points, tets, self.view_projection(scene, textures.centre), img.width, img.height,
                           orders.fast, tile, tiles)
        return reached, tiles

    def _host_fan(self, scene, textures):
        """The mesh's :class:`.fan.HostFan` (kept per mesh) where this frame's Shirley-Tuchman fan is built on
        the host (:attr:`host_fan` and numba installed), else ``None`` (``pt.geom`` builds it)."""
        fast = compiled_fan() if self.host_fan else None
        if fast is None:
            return None
        mesh = scene.field
        return self._cached("host fan", (mesh,), lambda: HostFan(self.ctx, mesh, textures.centre, fast))

    def _shirley_tuchman(self, scene, defines: dict) -> bool:
        """Whether this frame takes Shirley and Tuchman's interpolation (``renderer.integration``):
        emission-absorption only, and the exact path where it does not apply: the camera reaching the
        mesh (cells with no projection), clipping or opaque geometry (the kept part of each pixel's
        ray, which the thick vertex's one ray cannot stand for), the fragment counts."""
        return (getattr(scene.renderer, "integration", "exact") == "shirley-tuchman" and "EMISSION" in defines
                and not self._count_fragments and not (defines.get("CLIPPING") or defines.get("GEOMETRY"))
                and not MeshRenderer._reaches_near_plane(scene))

    def fragment_counts(self, scene) -> np.ndarray:
        """``(height, width)``: how many cells' fragments each pixel keeps (a ray's pieces found by the
        fragments), added up, for tests of the footprint: one fragment per cell a ray crosses."""
        self._count_fragments = True
        try:
            return self.render(scene.with_renderer(compositing="average"))[..., 0]
        finally:
            self._count_fragments = False

    def _gap_pixels(self, scene, textures, orders) -> np.ndarray | None:
        """Which pixels' rays may leave the mesh and enter it again (the only rays the exact order
        casts against the boundary): those crossing at least three boundary faces, counted by drawing
        the boundary with additive blending, and their neighbours (the rasterizer's rounding at a
        fold of the boundary may count a crossing less).  ``None`` (every ray) when the mesh reaches
        the eye's plane, where rays start inside it and the plane would clip what they cross; none
        (and nothing drawn) when the boundary is convex (:attr:`.order.Adjacency.convex`)."""
        img = scene.image
        if self._reaches_near_plane(scene):
            return None
        if orders.adjacency.convex:  # no ray crosses it more than twice
            return np.zeros(img.height * img.width, bool)
        buffer, count = textures.boundary(orders.adjacency)
        gaps = np.zeros((img.height, img.width), bool)
        if buffer is None:
            return gaps.reshape(-1)
        program = create_program(self.ctx, "boundary.vert", "boundary.frag", roots=SHADERS)
        self._uniforms(program, scene, textures)
        (_,), fbo = self.target("counts", img.width, img.height, (1,))
        vao = self.ctx.vertex_array(program, [(buffer, "3f", "in_position")])
        try:
            fbo.use()
            fbo.viewport = (0, 0, img.width, img.height)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            self._blending("average")  # additive
            self.ctx.disable(moderngl.CULL_FACE)  # both ways: every crossing counts
            vao.render(moderngl.TRIANGLES, vertices=3 * count)
            crossings = self.read(fbo, img.width, img.height, components=1)[..., 0]  # rows from the top
        finally:
            self._blending(None)
            vao.release()
        many = crossings >= 3  # rows from the top, as Camera.pixel_rays
        grown = many.copy()  # and the eight neighbours
        grown[1:] |= many[:-1]
        grown[:-1] |= many[1:]
        grown[:, 1:] |= grown[:, :-1].copy()
        grown[:, :-1] |= grown[:, 1:].copy()
        return grown.reshape(-1)

    def _order_texture(self, order: np.ndarray):
        texels = rows(np.ascontiguousarray(order, dtype=np.uint32), np.uint32, components=1)
        tex = self.ctx.texture((ROW, texels.shape[0]), 1, texels.tobytes(), dtype="u4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return tex

    @staticmethod
    def _flag_cover_all(order: np.ndarray, scene) -> np.ndarray:
        """The order with :data:`COVER_ALL` set on the cells with a vertex at or behind the GL near plane
        of a perspective camera (inside the mesh, or the plane through it): such a vertex has no
        projection, so the cell covers the whole image and every fragment clips its own ray.  Nothing
        to flag (and nothing computed) when the mesh's box lies beyond the plane; an orthographic
        projection holds for every vertex."""
        mesh = scene.field
        if scene.camera.projection != "perspective" or not MeshRenderer._reaches_near_plane(scene):
            return order
        near, forward = MeshRenderer._near_plane(scene)
        depth = (mesh.points - np.asarray(scene.camera.eye)) @ forward
        behind = depth[mesh.tets].min(axis=1) <= near
        return np.where(behind[order], order.astype(np.uint32) | COVER_ALL, order.astype(np.uint32))

    def _blending(self, mode):
        ctx = self.ctx
        if mode is None:
            ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE)
            ctx.blend_equation = moderngl.FUNC_ADD
            ctx.blend_func = moderngl.DEFAULT_BLENDING
            return
        ctx.enable(moderngl.CULL_FACE)  # the footprints face the eye (pt.geom)
        ctx.front_face, ctx.cull_face = "ccw", "back"
        if mode == "isosurface":
            ctx.disable(moderngl.BLEND)
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            return
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = {"mip": moderngl.MAX, "minip": moderngl.MIN}.get(mode, moderngl.FUNC_ADD)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA) if mode == "emission_absorption" \
            else (moderngl.ONE, moderngl.ONE)

