"""``slicing2d``: three stacks of 2D slices (texture arrays), the most view-aligned one drawn.

The stacks are built when first needed; the stack whose axis is closest to the view direction
is drawn, a quad per voxel plane, bilinear within slices.  The distance between slices along a
ray then changes with the view (opacity is corrected for it per fragment), and the picture jumps
when the stack switches (see ``dvr bench slicing``).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ...reference import plans
from ..grid.slicing import SlicingRenderer, core_box
from ..grid.textures import FORMATS, texels


class Slicing2DRenderer(SlicingRenderer):
    name = "slicing2d"
    description = "three stacks of 2D slices, the most view-aligned one blended back to front (GPU)"
    stack = True

    def grid_texture_limit(self, gl) -> int:
        """A stack is a 2D texture array: slices a side at most the texture size, layers at most the
        array-layer limit (larger volumes are rendered in bricks that fit both)."""
        return min(gl.texture_size, gl.array_layers)

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

    def geometry(self, scene, view) -> np.ndarray:
        """A quad per voxel plane across the stack's axis (within this view's core), back to front."""
        volume, cam = scene.volume, scene.camera
        axis = self.axis(scene)
        f, _, _ = cam.basis()
        lo, hi = core_box(scene, view)
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
        dtype, scale, offset, _ = FORMATS[data.dtype]
        data = texels(data)
        layers = {2: data, 1: data.transpose(1, 0, 2), 0: data.transpose(2, 0, 1)}[axis]  # [layer, row, col]
        n, h, w = layers.shape
        self.texture = ctx.texture_array((w, h, n), 1, np.ascontiguousarray(layers).tobytes(), dtype=dtype)
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = self.texture.repeat_y = False
        self.value_scale, self.value_offset = scale, offset

    def uniforms(self) -> dict:
        """What turns its texels back into data values (bound with it: :meth:`dvr_gl.gl.frame.GLFrame.bind`)."""
        return {"u_value_scale": self.value_scale, "u_value_offset": self.value_offset}
