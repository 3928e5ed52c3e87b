"""Projected tetrahedra in GL (see the package doc and ``docs/meshes.md``).

The mesh goes to the GPU once (points relative to its centre, so float32 keeps their precision;
cells; each cell's face planes and scalar as ``g . p + c``, computed in float64), as textures of
4096 texels a row; a frame uploads only the visibility order (a texture: no vertex buffer; each
cell's footprint is drawn by ``pt.geom``).
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
from ...errors import SceneError
from ...fields.mesh_rays import FacePlanes
from ...gl.context import create_context, make_current, release_context
from ...gl.geometry import box_corners, clip_planes, gl_matrix, projection_matrix, view_matrix
from ...gl.shaders import create_program, release_programs
from ...rays import RayBatch
from ...reference.converged import collocation
from ...transfer_function import segment_opacity
from ..base import Renderer
from .order import VisibilityOrder

ROW = 4096  # texels a row of the mesh textures (mesh_fetch.glsl)
CELL_TEXELS = 6  # a cell's face planes, their sides and its scalar (mesh_fetch.glsl)
# How far the footprint is grown (pt.geom), pixels.  The rasterizer snaps vertices to a sub-pixel grid
# (llvmpipe: 1/256 pixel), so a pixel centre just inside a cell's silhouette can fall outside the
# drawn footprint, and with it a piece of the cell (all of a thin cell seen edge on): without a
# margin the blunt fin was off by RMS 4e-5 to 8e-5 (2.5e-7 with one).  A twentieth of a pixel covers
# the snapping at a fraction of the fragments a whole pixel adds (20-30 % more draw time).
MARGIN_PIXELS = 0.05
COVER_ALL = np.uint32(1 << 31)  # an order entry's flag: the cell reaches behind the eye's plane (pt.vert)
MODES = {"emission_absorption": "EMISSION", "mip": "MIP", "minip": "MINIP", "average": "AVERAGE",
         "isosurface": "ISOSURFACE"}


def _rows(array: np.ndarray, dtype, components: int = 4) -> np.ndarray:
    """``(n, components)`` as ``(rows, ROW, components)`` texels, zero-padded."""
    rows = max(1, -(-len(array) // ROW))
    out = np.zeros((rows * ROW, components), dtype=dtype)
    out[:len(array)] = array.reshape(len(array), components)
    return out.reshape(rows, ROW, components)


def cell_texels(points: np.ndarray, tets: np.ndarray, gradients: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """``(M * CELL_TEXELS, 4)``: each cell's face planes ``(n, h)`` (as :class:`FacePlanes`, so the cells
    sharing a face hold the same plane), the side of each its inside lies on, and its scalar ``(g, c)``."""
    planes = FacePlanes(points, tets)
    out = np.zeros((len(tets), CELL_TEXELS, 4))
    out[:, :4, :3], out[:, :4, 3], out[:, 4] = planes.normal, planes.offset, planes.side
    out[:, 5, :3], out[:, 5, 3] = gradients, offsets
    return out.reshape(-1, 4)


class MeshTextures:
    """One mesh on the GPU."""

    def __init__(self, ctx, mesh):
        lo, hi = (np.asarray(b, float) for b in mesh.bounds)
        self.centre = 0.5 * (lo + hi)
        rec = mesh.reconstruct()
        points = mesh.points - self.centre
        offset = rec.base - np.einsum("ij,ij->i", rec.gradients, rec.anchor - self.centre)
        planes = cell_texels(points, mesh.tets, rec.gradients, offset)
        self.textures = []
        for name, data, dtype in (("u_points", np.c_[points, np.zeros(len(points))], "f4"),
                                  ("u_cells", mesh.tets, "u4"), ("u_cell_planes", planes, "f4")):
            texels = _rows(data, np.float32 if dtype == "f4" else np.uint32)
            tex = ctx.texture((ROW, texels.shape[0]), 4, texels.tobytes(), dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.textures.append((name, tex))
        self.cells = len(mesh.tets)
        self.ctx = ctx
        self._boundary = None  # the boundary faces' vertices (a buffer), once asked for
        values = mesh.values[mesh.tets] if mesh.association == "point" else mesh.values[:, None]
        self.cell_ranges = (values.min(axis=1), values.max(axis=1))  # each cell's scalar range
        self._visible = None  # (transfer function, mask)

    def visible(self, tf) -> np.ndarray:
        """Which cells hold some opacity under ``tf`` (once per transfer function): the opacity column
        is linear between control points and never negative, so it is zero over a cell's scalar range
        exactly when it is zero at both ends and at every control value between them.  The others add
        nothing (premultiplied (0, 0)) and are not drawn."""
        if self._visible is None or self._visible[0] is not tf:
            lo, hi = self.cell_ranges
            values, column = tf.points[:, 0], tf.points[:, 4]
            nonzero = np.r_[0, np.cumsum(column > 0)]  # control points with opacity, up to each index
            inner = nonzero[np.searchsorted(values, hi, "left")] - nonzero[np.searchsorted(values, lo, "right")]
            ends = (np.interp(lo, values, column) > 0) | (np.interp(hi, values, column) > 0)
            self._visible = (tf, ends | (inner > 0))
        return self._visible[1]

    def boundary(self, adjacency):
        """A buffer of the mesh's boundary triangles (centre-relative float32 vertices) and their count."""
        if self._boundary is None:
            corners = (adjacency.boundary_corners - self.centre).astype(np.float32)
            self._boundary = (self.ctx.buffer(corners.tobytes()) if len(corners) else None, len(corners))
        return self._boundary

    def release(self):
        for _, tex in self.textures:
            tex.release()
        if self._boundary is not None and self._boundary[0] is not None:
            self._boundary[0].release()


class ProjectedTetrahedraRenderer(Renderer):
    name = "projected-tetrahedra"
    description = "projected tetrahedra in GL for meshes, exact visibility order"

    def __init__(self, ctx=None):
        super().__init__()
        self.ctx = ctx or create_context()
        self._owns_context = ctx is None
        self._mesh = None        # (mesh, MeshTextures, VisibilityOrder)
        self._targets = {}       # name: (size, GL objects..., framebuffer last): see _sized
        self._count_fragments = False

    # --- limits ---

    def check_resources(self, scene):
        super().check_resources(scene)
        make_current(self.ctx)
        gl = limits.gl_limits(self.ctx)
        limits.check_image(scene, gl)
        limits.check_image_memory(scene, "gpu")
        mesh = scene.field
        rows = -(-max(len(mesh.points), CELL_TEXELS * len(mesh.tets)) // ROW)
        limits.check_texture("the mesh", (ROW, rows), gl, "use a smaller mesh")
        points = len(scene.transfer_function.points)
        if scene.renderer.compositing == "emission_absorption" and points > self.max_tf_points():
            raise SceneError(f"transfer_function.points: {points} control points; projected-tetrahedra keeps them "
                             f"in uniforms and this GL holds at most {self.max_tf_points()}: use fewer points")

    def max_tf_points(self) -> int:
        """Control points the fragment shader's uniforms hold: two vectors each, 64 kept for the rest."""
        vectors = int(self.ctx.info["GL_MAX_FRAGMENT_UNIFORM_COMPONENTS"]) // 4
        return max(vectors - 64, 0) // 2

    # --- resources ---

    def _mesh_resources(self, mesh):
        if self._mesh is None or self._mesh[0] is not mesh:
            if self._mesh is not None:
                self._mesh[1].release()
            self._mesh = (mesh, MeshTextures(self.ctx, mesh), VisibilityOrder(mesh))
        return self._mesh[1], self._mesh[2]

    def _sized(self, name: str, width: int, height: int, make):
        """The framebuffer of target ``name``, made by ``make(size)`` (GL objects, the framebuffer last)
        and kept while the size holds."""
        entry = self._targets.get(name)
        if entry is None or entry[0] != (width, height):
            if entry is not None:
                for obj in entry[1:]:
                    obj.release()
            entry = self._targets[name] = ((width, height), *make((width, height)))
        return entry[-1]

    def _count_target(self, width: int, height: int):
        """A one-channel float framebuffer for the boundary's crossing counts."""
        def make(size):
            counts = self.ctx.texture(size, 1, dtype="f4")
            return counts, self.ctx.framebuffer([counts])
        return self._sized("counts", width, height, make)

    def _framebuffer(self, width: int, height: int):
        def make(size):
            colour, depth = self.ctx.texture(size, 4, dtype="f4"), self.ctx.depth_texture(size)
            return colour, depth, self.ctx.framebuffer([colour], depth)
        return self._sized("image", width, height, make)

    # --- a frame ---

    def draw(self, scene) -> np.ndarray:
        make_current(self.ctx)
        r, cam, img, mesh = scene.renderer, scene.camera, scene.image, scene.field
        mode = r.compositing
        start = time.perf_counter()
        textures, orders = self._mesh_resources(mesh)
        if mode == "emission_absorption":
            gaps = self._gap_pixels(scene, textures, orders) if r.cell_order == "exact" else None
            order, stats = orders(cam, img.width, img.height, r.cell_order, pixels=gaps)
            # transparent cells are ordered (the relations run through them) but not drawn
            order = order[textures.visible(scene.transfer_function)[order]][::-1]  # drawn back to front
            stats["order_seconds"] = time.perf_counter() - start  # with the boundary's count in GL
        else:
            order, stats = np.arange(textures.cells), {"order": "none (blended)", "order_seconds": 0.0}
        drawn = time.perf_counter()
        tf = scene.transfer_function
        defines = {MODES[mode]: True, "CAMERA_ORTHOGRAPHIC": cam.projection == "orthographic"}
        if mode == "emission_absorption":
            defines.update(ALPHA_MODEL=tf.opacity_model == "alpha", TF_COUNT=len(tf.points),
                           TF_POW2=1 << len(tf.points).bit_length())
        if self._count_fragments:
            defines = {"FRAGMENT_COUNT": True, "CAMERA_ORTHOGRAPHIC": defines["CAMERA_ORTHOGRAPHIC"]}
        program = create_program(self.ctx, "cells/pt.vert", "cells/pt.frag", defines, geometry="cells/pt.geom")
        self._uniforms(program, scene, textures)
        slots = self._order_texture(self._flag_cover_all(order, scene))
        for unit, (name, tex) in enumerate([*textures.textures, ("u_order", slots)]):
            tex.use(location=unit)
            if name in program:
                program[name].value = unit
        fbo = self._framebuffer(img.width, img.height)
        fbo.use()
        fbo.viewport = (0, 0, img.width, img.height)
        clear = {"mip": (-3.0e38, 0.0), "minip": (3.0e38, 0.0)}.get(mode, (0.0, 0.0))
        fbo.clear(clear[0], clear[1], 0.0, 0.0, depth=1.0)
        self._blending(mode)
        vao = self.ctx.vertex_array(program, [])
        try:
            vao.render(moderngl.POINTS, vertices=len(order))
            raw = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(img.height, img.width, 4)
        finally:
            vao.release()
            slots.release()
            self._blending(None)
        image = raw[::-1].astype(np.float64)
        now = time.perf_counter()
        self.stats = {**stats, "draw_seconds": now - drawn, "seconds": now - start, "cells": textures.cells,
                      "cells_drawn": len(order),
                      "cells_per_second": textures.cells / max(now - start, 1e-12)}
        if mode == "emission_absorption" or self._count_fragments:
            return image.astype(np.float32)
        return self._resolve(scene, image).astype(np.float32)

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
        the eye's plane, where rays start inside it and the plane would clip what they cross."""
        img = scene.image
        if self._reaches_near_plane(scene):
            return None
        buffer, count = textures.boundary(orders.adjacency)
        gaps = np.zeros((img.height, img.width), bool)
        if buffer is None:
            return gaps.reshape(-1)
        program = create_program(self.ctx, "cells/boundary.vert", "cells/boundary.frag")
        self._uniforms(program, scene, textures)
        fbo = self._count_target(img.width, img.height)
        vao = self.ctx.vertex_array(program, [(buffer, "3f", "in_position")])
        try:
            fbo.use()
            fbo.viewport = (0, 0, img.width, img.height)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            self._blending("average")  # additive
            self.ctx.disable(moderngl.CULL_FACE)  # both ways: every crossing counts
            vao.render(moderngl.TRIANGLES, vertices=3 * count)
            crossings = np.frombuffer(fbo.read(components=1, dtype="f4"), np.float32).reshape(img.height, img.width)
        finally:
            self._blending(None)
            vao.release()
        many = crossings[::-1] >= 3  # rows from the top, as Camera.pixel_rays
        grown = many.copy()  # and the eight neighbours
        grown[1:] |= many[:-1]
        grown[:-1] |= many[1:]
        grown[:, 1:] |= grown[:, :-1].copy()
        grown[:, :-1] |= grown[:, 1:].copy()
        return grown.reshape(-1)

    @staticmethod
    def _near_plane(scene) -> tuple[float, np.ndarray]:
        """The GL near plane's distance from the eye along the view axis, with a margin for float32
        rounding there, and the view axis."""
        lo, hi = (np.asarray(b, float) for b in scene.field.bounds)
        near, _ = clip_planes(scene.camera, lo, hi)
        forward, _, _ = scene.camera.basis()
        return near + 1e-6 * float(np.linalg.norm(hi - lo)), forward

    @staticmethod
    def _reaches_near_plane(scene) -> bool:
        """Whether the mesh's box reaches the GL near plane."""
        near, forward = ProjectedTetrahedraRenderer._near_plane(scene)
        corners = box_corners(*scene.field.bounds)
        return bool(((corners - np.asarray(scene.camera.eye)) @ forward).min() <= near)

    def _order_texture(self, order: np.ndarray):
        texels = _rows(np.ascontiguousarray(order, dtype=np.uint32), np.uint32, components=1)
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
        if scene.camera.projection != "perspective" or not ProjectedTetrahedraRenderer._reaches_near_plane(scene):
            return order
        near, forward = ProjectedTetrahedraRenderer._near_plane(scene)
        depth = (mesh.points - np.asarray(scene.camera.eye)) @ forward
        behind = depth[mesh.tets].min(axis=1) <= near
        return np.where(behind[order], order.astype(np.uint32) | COVER_ALL, order.astype(np.uint32))

    def _uniforms(self, program, scene, textures):
        cam, img, r = scene.camera, scene.image, scene.renderer
        lo, hi = scene.field.bounds
        near, far = clip_planes(cam, lo, hi)
        translate = np.eye(4)
        translate[:3, 3] = textures.centre
        vp = projection_matrix(cam, img.width / img.height, near, far) @ view_matrix(cam) @ translate
        f, right, up = cam.basis()
        x, w, s = collocation(4)
        values = {"u_image_size": (img.width, img.height), "u_margin": MARGIN_PIXELS,
                  "u_eye": tuple(np.asarray(cam.eye) - textures.centre), "u_forward": tuple(f),
                  "u_right": tuple(right), "u_up": tuple(up),
                  "u_half_extent": cam.half_extent(img.width / img.height), "u_near": cam.near,
                  "u_iso_value": r.iso_value if r.iso_value is not None else 0.0,
                  "u_depth_scale": 1.0 / self._far(scene),
                  "u_unit_distance": scene.transfer_function.unit_distance,
                  "u_gauss_x": tuple(0.5 * (x + 1.0)), "u_gauss_w": tuple(0.5 * w)}
        for name, value in values.items():
            if name in program:
                program[name].value = value
        if "u_view_projection" in program:
            program["u_view_projection"].write(gl_matrix(vp))
        if "u_gauss_s" in program:
            # S on [0, 1]: integral from 0 to x_i of l_j = half of that on [-1, 1]; column j, row i
            program["u_gauss_s"].write(np.ascontiguousarray((0.5 * s).T, dtype=np.float32).tobytes())
        if "u_tf_value_opacity" in program:
            p = scene.transfer_function.points
            program["u_tf_value_opacity"].write(np.ascontiguousarray(p[:, [0, 4]], dtype=np.float32).tobytes())
            program["u_tf_rgb"].write(np.ascontiguousarray(p[:, 1:4], dtype=np.float32).tobytes())

    @staticmethod
    def _far(scene) -> float:
        """The largest ray parameter inside the mesh's box (the isosurface's depth scale)."""
        corners = box_corners(*scene.field.bounds)
        return float(np.linalg.norm(corners - np.asarray(scene.camera.eye), axis=1).max()) * 1.01 + 1e-30

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

    @staticmethod
    def _resolve(scene, image) -> np.ndarray:
        """Classify a projection's blended value (``.r``) where a fragment came (``.g``), with the exact
        transfer function and the opacity of one unit distance; the isosurface: its colour, opaque."""
        mode, tf = scene.renderer.compositing, scene.transfer_function
        value, flag = image[..., 0], image[..., 1]
        covered = flag < 0 if mode == "minip" else flag > 0
        if mode == "isosurface":
            value = np.full(value.shape, scene.renderer.iso_value)
        elif mode == "average":
            rays = RayBatch.for_camera(scene.camera, scene.image.width, scene.image.height, scene.field.bounds)
            length = (rays.t1 - rays.t0).reshape(value.shape)
            value = np.where(length > 0, value / np.where(length > 0, length, 1.0), 0.0)
        colour, sigma = tf.evaluate(value[covered])
        alpha = 1.0 if mode == "isosurface" else segment_opacity(sigma, tf.unit_distance)
        out = np.zeros(image.shape)
        out[covered, :3] = colour * np.reshape(alpha, (-1, 1))
        out[covered, 3] = alpha
        return out

    def close(self):
        make_current(self.ctx)
        if self._mesh is not None:
            self._mesh[1].release()
        for entry in self._targets.values():
            for obj in entry[1:]:
                obj.release()
        self._mesh, self._targets = None, {}
        if self._owns_context:
            release_programs(self.ctx)
            release_context(self.ctx)
