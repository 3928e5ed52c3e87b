"""Texture slicing, shared by ``slicing3d`` and ``slicing2d``: proxy slices drawn back to front and
blended with the over operator.

:class:`SlicingRenderer` draws a renderer's slices (its ``geometry``) brick by brick; the
plugins :mod:`dvr_gl.renderers.slicing3d` (view-aligned planes through a 3D texture) and
:mod:`dvr_gl.renderers.slicing2d` (object-aligned 2D stacks) supply the geometry.  Both composite emission-absorption with post-, pre- (3D only) or pre-integrated
classification, shading and gradient opacity; every slice is blended (no early
termination).  The same-discretization reference samples the same planes, clipped by
the same near plane: :func:`reference`.
"""

from __future__ import annotations

import numpy as np

from .bricking import visibility_order
from ...gl.geometry import clip_planes, gl_matrix, projection_matrix, view_matrix
from ...gl.shaders import create_program
from ...reference import plans
from ...reference.discrete import DiscreteReference
from .gl_base import GLVolumeRenderer, classification_features, now

MAX_REACH = 64.0  # voxels: rays this close to parallel with the slices need more ghost than any brick has


def reference_plan(scene, kind: str):
    """The sample plan of ``slicing3d`` or ``slicing2d`` for :class:`~dvr_gl.reference.discrete.DiscreteReference`."""
    if kind == "slicing3d":
        return lambda rays: plans.view_planes(rays, scene.camera, scene.volume.box, scene.renderer.sample_distance)
    return lambda rays: plans.axis_planes(rays, scene.camera, scene.volume)


def reference(scene, kind: str) -> DiscreteReference:
    """The same-discretization reference of a slicer: its planes, and its near clip plane."""
    near, _ = clip_planes(scene.camera, *scene.volume.box)
    clipped = scene.replace(camera=scene.camera.with_(near=near))
    return DiscreteReference(clipped, plan=reference_plan(clipped, kind))


def same_planes_3d(scene) -> np.ndarray:
    """``slicing3d``'s oracle: the float64 image of the same view-aligned planes."""
    return reference(scene, "slicing3d").render_float64()


def same_planes_2d(scene) -> np.ndarray:
    """``slicing2d``'s oracle: the float64 image of the same voxel planes."""
    return reference(scene, "slicing2d").render_float64()


class SlicingRenderer(GLVolumeRenderer):
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
        self.activate()
        start = now()
        defines = classification_features(scene)
        if self.stack:
            defines["STACK"] = True
        program = create_program(self.ctx, "slice.vert", "slice.frag", defines)
        tables = self.table_textures(scene, defines, self.slab_length(scene))
        views = self.grid_views(scene, defines)
        per_voxel = scene.volume.data.itemsize + self.texture_bytes_per_voxel(defines)
        resident = sum(np.prod(v.dims) for v in views) * per_voxel <= scene.renderer.texture_budget_mb * 2 ** 20
        if len(views) > 1:
            order = visibility_order([v.brick for v in views], scene.volume, scene.camera, front_to_back=False)
            views = [next(v for v in views if v.brick is b) for b in order]
        width, height = scene.image.width, scene.image.height
        (_,), fbo = self.target("main", width, height)
        fbo.use()
        self.ctx.viewport = (0, 0, width, height)
        self.ctx.clear(0.0, 0.0, 0.0, 0.0)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
        self.ctx.enable(self.ctx.BLEND)
        self.ctx.blend_func = (self.ctx.ONE, self.ctx.ONE_MINUS_SRC_ALPHA)  # over, premultiplied
        common = {**self.camera_uniforms(scene), **self.optics_uniforms(scene, tables["u_lut"].lut)}
        gpu_seconds, triangles = 0.0, 0
        try:
            for view in views:
                tris = self.geometry(scene, view)
                if not len(tris):
                    continue
                textures = {**self.volume_textures(scene, defines, view, resident), **tables}
                self.bind(program, {**common, **self.grid_uniforms(scene, view), **self.view_uniforms(scene)},
                          textures)
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
        image = self.read(fbo, width, height)
        self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines,
                      "bricks": len(views), "triangles": triangles}
        return image

    def volume_textures(self, scene, defines, view, resident) -> dict:
        return self.view_textures(scene, defines, view, resident)

    def view_uniforms(self, scene) -> dict:
        f, _, _ = scene.camera.basis()
        return {"u_slice_normal": f, "u_slab_length": self.slab_length(scene)}

    @staticmethod
    def camera_uniforms(scene) -> dict:
        cam, img, vol = scene.camera, scene.image, scene.volume
        near, far = clip_planes(cam, *vol.box)
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


def core_box(scene, view):
    """The world box of what a grid view owns: the volume's, or its brick's core."""
    if view.brick is None:
        return scene.volume.box
    return view.brick.world_box(scene.volume)
