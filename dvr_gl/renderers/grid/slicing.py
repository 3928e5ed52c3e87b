"""Texture slicing, shared by the slicers: proxy slices drawn back to front and blended with the over
operator.

:class:`SlicingRenderer` draws a renderer's slices (its ``geometry``) brick by brick; each slicer
supplies the geometry (view-aligned planes through a 3D texture, or object-aligned 2D stacks with
``stack = True``).  They composite emission-absorption with post-, pre- (3D textures only) or
pre-integrated classification, shading and gradient opacity; every slice is blended (no early
termination).  The same-discretization reference samples the same planes, clipped by the same near
plane: :func:`reference`, given the slicer's planes (its oracle says which).
"""

from __future__ import annotations

from time import perf_counter as now

import moderngl
import numpy as np

from ...gl.geometry import clip_planes, gl_matrix, projection_matrix, slice_polygons, view_matrix
from ...gl.scattering import light_volume_pass_defines
from ...gl.shaders import create_program, shader_root
from ...half_angle import half_angle
from ...reference import plans
from ...reference.discrete import DiscreteReference
from ..surfaces import with_surfaces
from .bricking import visibility_order
from .classification import classification_features
from .sampling import GridRenderer
from .textures import texel_bytes

#: The grid kit's GLSL (the slices' program), before the common library.
SHADERS = (shader_root(__file__),)

MAX_REACH = 64.0  # voxels: rays this close to parallel with the slices need more ghost than any brick has


def view_planes(scene):
    """The sample plan (:mod:`dvr_gl.reference.plans`) of planes ``renderer.sample_distance`` apart facing
    the eye, or half-way to the light where half-angle slicing lights them (:func:`half_angle_of`)."""
    ha = half_angle_of(scene)
    return lambda rays: plans.view_planes(rays, scene.camera, scene.field.box, scene.renderer.sample_distance,
                                          None if ha is None else ha.normal)


def voxel_planes(scene):
    """The sample plan of the voxel planes across the axis that faces the eye most squarely."""
    return lambda rays: plans.axis_planes(rays, scene.camera, scene.volume)


def half_angle_of(scene):
    """Half-angle slicing's geometry (:mod:`dvr_gl.half_angle`) where the scene asks for it (with shadows:
    without, nothing needs the light buffer and the slices face the eye), else None."""
    sc = scene.renderer.scattering
    if not (sc.enabled and sc.shadows and sc.method == "half_angle"):
        return None
    return half_angle(scene.camera, scene.field.box, sc.lights[0].direction, scene.renderer.sample_distance,
                      sc.light_buffer_size)


def reference(scene, planes) -> DiscreteReference:
    """The same-discretization reference of a slicer: its planes (``planes(scene)``, a sample plan:
    :func:`view_planes`, :func:`voxel_planes`), clipped by its near clip plane."""
    near, _ = clip_planes(scene.camera, *scene.field.box)
    clipped = scene.replace(camera=scene.camera.with_(near=near))
    return DiscreteReference(clipped, plan=planes(clipped))


class SlicingRenderer(GridRenderer):
    stack = False  # 2D texture stacks instead of a 3D texture

    def slab_length(self, scene) -> float:
        return scene.renderer.sample_distance

    def brick_reach(self, scene) -> float:
        """Pre-integrated slabs read the scalar where the ray meets the next slice, ``d / cos`` away
        along the ray (largest at the image's corners)."""
        if scene.renderer.classification != "preintegrated":
            return 0.0
        normal = self.view_uniforms(scene)["u_slice_normal"]
        dirs = scene.camera.corner_directions(scene.image.width, scene.image.height)
        along = np.abs(dirs @ normal)
        steps = self.slab_length(scene) * np.abs(dirs) / np.maximum(along, 1e-9)[:, None]
        return float(min(np.max(steps / np.asarray(scene.volume.spacing)), MAX_REACH))

    def draw(self, scene) -> np.ndarray:
        """The frame; with ``[[renderer.geometry]]`` the meshes are drawn first (:mod:`.surfaces`), the
        slices' fragments behind them discarded, and the slices composited over them."""
        return with_surfaces(self, scene, self._draw_volume)

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        self.activate()
        start = now()
        defines = classification_features(scene)
        if self.stack:
            defines["STACK"] = True
        program = create_program(self.ctx, "slice.vert", "slice.frag", defines, roots=SHADERS)
        tables = {**self.table_textures(scene, defines, self.slab_length(scene)), **surfaces}
        views = self.grid_views(scene, defines)
        tables, light_seconds = self.scattering_tables(scene, defines, views, tables)
        if "HALF_ANGLE" in defines:
            return self._draw_half_angle(scene, defines, program, tables, views[0], start)
        per_voxel = texel_bytes(scene.volume.dtype) + self.texture_bytes_per_voxel(defines)
        resident = sum(np.prod(v.dims) for v in views) * per_voxel <= scene.renderer.texture_budget_mb * 2 ** 20
        if len(views) > 1:
            order = visibility_order([v.brick for v in views], scene.volume, scene.camera, front_to_back=False)
            views = [next(v for v in views if v.brick is b) for b in order]
        common = {**self.camera_uniforms(scene), **self.optics_uniforms(scene, tables["u_lut"].lut)}

        def passes():
            for view in views:
                tris = self.geometry(scene, view)
                if len(tris):
                    textures = {**self.volume_textures(scene, defines, view, resident), **tables}
                    yield {**common, **self.grid_uniforms(scene, view), **self.view_uniforms(scene)}, textures, tris

        image, gpu_seconds, triangles = self.blend_passes(scene, program, passes())
        self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines,
                      "bricks": len(views), "triangles": triangles, "light_volume_seconds": light_seconds}
        return image

    def blend_passes(self, scene, program, passes, bind_more=None) -> tuple[np.ndarray, float, int]:
        """Draw each pass's slices, ``(uniforms, textures, triangles)``, into the frame's image with the
        over operator on premultiplied colour, in the order given (back to front); the image, the seconds
        spent drawing (uploads excluded) and the triangles drawn.  ``bind_more(program, unit)`` binds what
        :meth:`bind` cannot (a sampler array) from texture unit ``unit`` on, after each pass's textures."""
        width, height = scene.image.width, scene.image.height
        (_,), fbo = self.target("main", width, height)
        fbo.use()
        self.ctx.viewport = (0, 0, width, height)
        self.ctx.clear(0.0, 0.0, 0.0, 0.0)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
        self.ctx.enable(self.ctx.BLEND)
        self.ctx.blend_func = (self.ctx.ONE, self.ctx.ONE_MINUS_SRC_ALPHA)  # over, premultiplied
        gpu_seconds, triangles = 0.0, 0
        try:
            for uniforms, textures, tris in passes:
                self.bind(program, uniforms, textures)
                if bind_more is not None:
                    bind_more(program, len(textures))
                vbo = self.ctx.buffer(np.ascontiguousarray(tris, dtype=np.float32).tobytes())
                vao = self.ctx.vertex_array(program, [(vbo, "3f", "position")])
                try:
                    self.ctx.finish()         # uploads done: time the drawing alone, as the ray caster does
                    drawn = now()
                    vao.render(self.ctx.TRIANGLES)
                    self.ctx.finish()
                    gpu_seconds += now() - drawn
                finally:
                    vao.release()
                    vbo.release()
                triangles += len(tris) // 3
        finally:
            self.ctx.disable(self.ctx.BLEND)
        return self.read(fbo, width, height), gpu_seconds, triangles

    def _draw_half_angle(self, scene, defines, program, tables, view, start) -> np.ndarray:
        """Half-angle slicing (:mod:`dvr_gl.half_angle`): the slices in order from the light, each drawn
        into the eye buffer (under or over, lit by the light buffer) and then into the light buffer
        (adding its optical depth)."""
        ctx = self.ctx
        ha = half_angle_of(scene)
        lo, hi = scene.volume.box
        e1 = np.cross(ha.normal, [1.0, 0.0, 0.0] if abs(ha.normal[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(ha.normal, e1)
        ks = ha.order()
        # the light pass draws each slice's polygon in a box grown by a light-buffer pixel and keeps the
        # fragments inside the volume's box by their world position (light_slice.frag): the rasterizer
        # snaps vertices to a fraction of a pixel, so its own edges would decide the pixels along the
        # box's faces differently from the reference
        grow = max(ha.extent[0] / ha.size[0], ha.extent[1] / ha.size[1])
        meshes = []
        for box_lo, box_hi in ((lo, hi), (lo - grow, hi + grow)):
            tris = slice_polygons(ha.normal, ha.offsets(ks), box_lo, box_hi, ha.eye, e1, e2)   # (K, 10, 3, 3)
            finite = np.all(np.isfinite(tris), axis=(2, 3))
            counts = finite.sum(axis=1) * 3
            meshes.append((tris[finite].reshape(-1, 3), np.concatenate([[0], np.cumsum(counts)[:-1]]), counts))
        (vertices, firsts, counts), (light_vertices, light_firsts, light_counts) = meshes
        light_defines = {k: v for k, v in light_volume_pass_defines(defines).items() if k != "SHADOWS"}
        light_program = create_program(ctx, "slice.vert", "scattering/light_slice.frag", light_defines, roots=SHADERS)
        width, height = scene.image.width, scene.image.height
        (_,), eye_fbo = self.target("main", width, height)
        nx, ny = ha.size
        (light_buffer,), light_fbo = self.target("light buffer", nx, ny, (1,))
        light_buffer.filter = (moderngl.NEAREST, moderngl.NEAREST)
        light_fbo.use()
        ctx.viewport = (0, 0, nx, ny)
        ctx.clear(0.0, 0.0, 0.0, 0.0)
        eye_fbo.use()
        ctx.viewport = (0, 0, width, height)
        ctx.clear(0.0, 0.0, 0.0, 0.0)
        textures = {**self.volume_textures(scene, defines, view, True), **tables}
        common = {**self.optics_uniforms(scene, tables["u_lut"].lut), **self.grid_uniforms(scene, view),
                  "u_box_lo": lo, "u_box_hi": hi}
        self.bind(program, {**common, **self.camera_uniforms(scene), **self.view_uniforms(scene),
                            "u_slice_normal": ha.normal, "u_light_origin": ha.origin,
                            "u_light_u": ha.axis_u / ha.extent[0], "u_light_v": ha.axis_v / ha.extent[1],
                            "u_light_buffer_size": ha.size}, {**textures, "u_light_buffer": light_buffer})
        self.bind(light_program, {**common, "u_view_projection": _Matrix(_light_matrix(ha)),
                                  "u_light_length": ha.light_length}, textures)
        vbo = ctx.buffer(np.ascontiguousarray(vertices, dtype=np.float32).tobytes())
        light_vbo = ctx.buffer(np.ascontiguousarray(light_vertices, dtype=np.float32).tobytes())
        eye_vao = ctx.vertex_array(program, [(vbo, "3f", "position")])
        light_vao = ctx.vertex_array(light_program, [(light_vbo, "3f", "position")])
        under = (ctx.ONE_MINUS_DST_ALPHA, ctx.ONE)   # front to back, premultiplied
        over = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.enable(ctx.BLEND)
        try:
            ctx.finish()
            drawn = now()
            for first, count, light_first, light_count in zip(firsts, counts, light_firsts, light_counts):
                if count:
                    eye_fbo.use()
                    ctx.viewport = (0, 0, width, height)
                    ctx.blend_func = under if ha.eye_front_to_back else over
                    eye_vao.render(ctx.TRIANGLES, vertices=int(count), first=int(first))
                if light_count:
                    light_fbo.use()
                    ctx.viewport = (0, 0, nx, ny)
                    ctx.blend_func = (ctx.ONE, ctx.ONE)
                    light_vao.render(ctx.TRIANGLES, vertices=int(light_count), first=int(light_first))
            ctx.finish()
            gpu_seconds = now() - drawn
        finally:
            ctx.disable(ctx.BLEND)
            ctx.blend_func = over
            eye_vao.release()
            light_vao.release()
            vbo.release()
            light_vbo.release()
        image = self.read(eye_fbo, width, height)
        self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines, "bricks": 1,
                      "triangles": len(vertices) // 3, "slices": int((counts > 0).sum()),
                      "light_buffer": ha.size, "light_volume_seconds": 0.0}
        return image

    def volume_textures(self, scene, defines, view, resident) -> dict:
        return self.view_textures(scene, defines, view, resident)

    def view_uniforms(self, scene) -> dict:
        f, _, _ = scene.camera.basis()
        lo, hi = scene.field.box
        return {"u_slice_normal": f, "u_slab_length": self.slab_length(scene), "u_box_lo": lo, "u_box_hi": hi}

    @staticmethod
    def camera_uniforms(scene) -> dict:
        cam, img = scene.camera, scene.image
        near, far = clip_planes(cam, *scene.field.box)
        vp = projection_matrix(cam, img.width / img.height, near, far) @ view_matrix(cam)
        f, _, _ = cam.basis()
        return {"u_view_projection": _Matrix(vp), "u_eye": cam.eye, "u_forward": f}

    def bind(self, program, uniforms, textures):
        matrix = uniforms.pop("u_view_projection", None)
        if matrix is not None and "u_view_projection" in program:
            program["u_view_projection"].write(gl_matrix(matrix.m))
        super().bind(program, uniforms, textures)


class _Matrix:
    def __init__(self, m):
        self.m = m


def _light_matrix(ha) -> np.ndarray:
    """World to clip coordinates of the light buffer: orthographic along the light, its pixels the
    buffer's (dvr_gl.half_angle); depth 0 (nothing is depth-tested)."""
    m = np.zeros((4, 4))
    for row, (axis, extent) in enumerate(((ha.axis_u, ha.extent[0]), (ha.axis_v, ha.extent[1]))):
        m[row, :3] = 2.0 * axis / extent
        m[row, 3] = -2.0 * float(ha.origin @ axis) / extent - 1.0
    m[3, 3] = 1.0
    return m


def core_box(scene, view):
    """The world box of what a grid view owns: the volume's, or its brick's core."""
    if view.brick is None:
        return scene.field.box
    return view.brick.world_box(scene.volume)
