"""Texture slicing: proxy slices drawn back to front and blended with the over operator.

* ``slicing3d``: the volume as a 3D texture (or bricks of it), cut by planes
  perpendicular to the view axis, ``sample_distance`` apart and anchored at the
  box centre's depth; each plane's polygon (3 to 6 vertices) is computed per
  frame, clipped to the volume box (or to each brick's core box).
* ``slicing2d``: three stacks of 2D slices (texture arrays), one per axis, built
  when first needed; the stack whose axis is closest to the view direction is
  drawn, a quad per voxel plane, bilinear within slices.  The distance between
  slices along a ray then changes with the view (opacity is corrected for it per
  fragment), and the picture jumps when the stack switches (see ``dvr bench
  slicing``).

Both composite emission-absorption with post-, pre- (3D only) or pre-integrated
classification, shading and gradient opacity; every slice is blended (no early
termination).  The same-discretization reference samples the same planes, clipped by
the same near plane: :func:`reference`.
"""

from __future__ import annotations

import numpy as np

from ..bricking import visibility_order
from ..errors import SceneError
from ..gl.geometry import clip_planes, depth_range, gl_matrix, projection_matrix, slice_polygons, view_matrix
from ..gl.shaders import create_program
from ..reference import plans
from ..reference.discrete import DiscreteReference
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


class SlicingRenderer(GLVolumeRenderer):
    stack = False  # 2D texture stacks instead of a 3D texture

    def check(self, scene):
        r = scene.renderer
        if r.compositing != "emission_absorption":
            raise SceneError(f"{self.name} composites emission-absorption only; use renderer raycast for "
                             f"{r.compositing}")
        if r.jitter:
            raise SceneError(f"{self.name} draws fixed slices: renderer.jitter applies to raycast only")

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

    def render(self, scene) -> np.ndarray:
        self.activate()
        start = now()
        self.check(scene)
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


def _core_box(scene, view):
    if view.brick is None:
        return scene.volume.box
    return view.brick.world_box(scene.volume)


class Slicing3DRenderer(SlicingRenderer):
    name = "slicing3d"
    description = "3D texture, view-aligned slices blended back to front (GPU)"

    def geometry(self, scene, view) -> np.ndarray:
        """Triangles of the slices within this view's box, back to front, as a flat (N * 3, 3) array."""
        cam = scene.camera
        f, right, up = cam.basis()
        lo, hi = scene.volume.box
        d = scene.renderer.sample_distance
        centre = float(((lo + hi) / 2.0 - np.asarray(cam.eye)) @ f)
        near_depth, far_depth = depth_range(cam, *_core_box(scene, view))
        near_clip, _ = clip_planes(cam, lo, hi)
        k_lo = int(np.ceil((max(near_depth, near_clip) - centre) / d))
        k_hi = int(np.floor((far_depth - centre) / d))
        if k_hi < k_lo:
            return np.zeros((0, 3))
        depths = centre + np.arange(k_hi, k_lo - 1, -1) * d  # back to front
        box_lo, box_hi = _core_box(scene, view)
        if view.brick is not None:
            depths = self._own_planes(scene, view, depths, f)
        tris = slice_polygons(f, depths, box_lo, box_hi, cam.eye, right, up).reshape(-1, 3, 3)
        tris = tris[np.all(np.isfinite(tris), axis=(1, 2))]
        return tris.reshape(-1, 3)

    @staticmethod
    def _own_planes(scene, view, depths, f):
        """A plane lying exactly in a face shared by two bricks belongs to one of them (the lower)."""
        axis = int(np.argmax(np.abs(f)))
        if abs(abs(f[axis]) - 1.0) > 1e-12 or view.brick.last[axis]:
            return depths
        _, hi = view.brick.world_box(scene.volume)
        face = float((hi[axis] - scene.camera.eye[axis]) * f[axis])
        return depths[depths != face]


class Slicing2DRenderer(SlicingRenderer):
    name = "slicing2d"
    description = "three stacks of 2D slices, the most view-aligned one blended back to front (GPU)"
    stack = True

    def check(self, scene):
        super().check(scene)
        r = scene.renderer
        if r.filter not in ("nearest", "linear"):
            raise SceneError(f"slicing2d interpolates bilinearly within slices: use renderer.filter linear or "
                             f"nearest, not {r.filter}")
        if r.classification == "pre":
            raise SceneError("slicing2d classifies after interpolation: use classification post or preintegrated")
        if r.shading.enabled and r.gradient == "texture":
            raise SceneError("slicing2d computes gradients by central differences: set renderer.gradient to "
                             "central_differences")

    def axis(self, scene) -> int:
        return plans.stack_axis(scene.camera)

    def slab_length(self, scene) -> float:
        return scene.volume.spacing[self.axis(scene)]

    def view_uniforms(self, scene) -> dict:
        axis = self.axis(scene)
        normal = np.zeros(3)
        normal[axis] = 1.0
        others = [a for a in range(3) if a != axis]
        return {"u_slice_normal": normal, "u_slab_length": self.slab_length(scene),
                "u_axes": (others[0], others[1], axis)}

    def volume_textures(self, scene, defines, view, resident) -> dict:
        axis = self.axis(scene)
        volume = scene.volume
        tag = f"stack {axis} {view.tex_lo}" if resident else f"stack {axis}"
        data = view.brick.data(volume.data) if view.brick is not None else volume.data
        return {"u_stack": self._cached(tag, (volume, view.tex_lo, view.dims, axis),
                                        lambda: _StackTexture(self.ctx, data, axis))}

    def bind(self, program, uniforms, textures):
        stack = textures.get("u_stack")
        if stack is not None:
            uniforms = {**uniforms, "u_value_scale": stack.value_scale, "u_value_offset": stack.value_offset}
        super().bind(program, uniforms, textures)

    def geometry(self, scene, view) -> np.ndarray:
        """A quad per voxel plane across the stack's axis (within this view's core), back to front."""
        volume, cam = scene.volume, scene.camera
        axis = self.axis(scene)
        f, _, _ = cam.basis()
        lo, hi = _core_box(scene, view)
        n = volume.dims[axis]
        first, last = (0, n - 1) if view.brick is None else (view.brick.core_lo[axis], view.brick.core_hi[axis])
        if view.brick is not None and not view.brick.last[axis]:
            last -= 1  # a plane shared with the next brick is that brick's
        ks = np.arange(first, last + 1)
        coords = volume.origin[axis] + ks * volume.spacing[axis]
        distance = (coords - cam.eye[axis]) * np.sign(f[axis])
        coords = coords[np.argsort(-distance, kind="stable")]  # back to front
        b, c = [a for a in range(3) if a != axis]
        quad = np.zeros((len(coords), 6, 3))
        corners = [(lo[b], lo[c]), (hi[b], lo[c]), (hi[b], hi[c]), (lo[b], lo[c]), (hi[b], hi[c]), (lo[b], hi[c])]
        for i, (vb, vc) in enumerate(corners):
            quad[:, i, axis], quad[:, i, b], quad[:, i, c] = coords, vb, vc
        return quad.reshape(-1, 3)


class _StackTexture:
    """A volume's slices across an axis as a 2D texture array (layer = voxel index along it)."""

    def __init__(self, ctx, data: np.ndarray, axis: int):
        from ..gl.textures import FORMATS
        import moderngl

        dtype, scale, offset, _ = FORMATS[data.dtype]
        if data.dtype == np.int16:
            data = (data.astype(np.int32) + 32768).astype(np.uint16)
        layers = {2: data, 1: data.transpose(1, 0, 2), 0: data.transpose(2, 0, 1)}[axis]  # [layer, row, col]
        n, h, w = layers.shape
        self.texture = ctx.texture_array((w, h, n), 1, np.ascontiguousarray(layers).tobytes(), dtype=dtype)
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = self.texture.repeat_y = False
        self.value_scale, self.value_offset = scale, offset
