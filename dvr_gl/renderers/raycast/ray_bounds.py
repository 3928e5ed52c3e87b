"""Ray bounds: where each pixel's ray first enters and last leaves the blocks that are not empty.

Empty-space skipping by bounding geometry (as Hadwiger et al. 2005 start their rays at the
rasterized faces of active blocks): the faces between level-0 blocks that are empty under the
transfer function (extinction zero for every value the filter can produce in them, the
``(0, 0, 0, 0)`` class of :mod:`.acceleration`) and blocks that are not, and the faces of
non-empty blocks on the volume's boundary, are drawn once per frame into a two-channel float
target blended with MIN: ``(t, -t)`` of every face a pixel's ray crosses, so that the target
holds the first entry into and the last exit from the non-empty blocks along that ray.  The ray
caster then steps only the segments from one before the entry to one after the exit, on the same
segment grid as without bounds: the segments it leaves out lie in empty blocks, which add exactly
zero colour and optical depth, so the image is bit-identical, and the loop pays nothing per
sample for it (the in-loop skipping of :mod:`.acceleration` pays a block lookup per jump).

Units and conventions: block ``b`` of size ``B`` voxels covers voxel coordinates
``[b B, (b + 1) B]`` clipped to the volume's ``[0, n - 1]`` (a sample at ``u`` belongs to block
``floor(u / B)``); world position = origin + voxel coordinate * spacing; ``t`` is the ray parameter
of ``dvr_gl/gl/shaders/common/camera_ray.glsl`` (world units along the unit direction), computed per fragment
from the face's plane, not interpolated.  Emission-absorption only: an empty block changes no
other mode's result by being left out only in special cases (MIP of a ramp starting at zero, ...).
"""

from __future__ import annotations

import numpy as np

from ...gl.geometry import box_corners, depth_range

# A face's vertices per axis: the quad's corners as (u, v) offsets in the two other axes.
_QUAD = np.array([(0, 0), (1, 0), (1, 1), (0, 0), (1, 1), (0, 1)])


def occupied(level0: np.ndarray) -> np.ndarray:
    """Level-0 blocks ``(nbz, nby, nbx)`` that are not empty: extinction not zero (constant or not)."""
    return level0[..., 3] != 0.0


def block_edges(dims_axis: int, blocks: int, block_size: int) -> np.ndarray:
    """Voxel coordinates of the ``blocks + 1`` block boundaries along one axis, clipped to the volume."""
    return np.minimum(np.arange(blocks + 1) * block_size, dims_axis - 1).astype(np.float64)


def boundary_faces(occ: np.ndarray, block_size: int, dims, spacing, origin) -> np.ndarray:
    """The faces of the non-empty blocks' union as triangles: ``(6 F, 5)`` float32 rows of world
    position (x, y, z), the face's axis (0, 1, 2 for x, y, z) and its plane's world coordinate."""
    spacing, origin = np.asarray(spacing, np.float64), np.asarray(origin, np.float64)
    p = np.pad(occ, 1)  # (z, y, x); outside the volume: empty
    edges = [block_edges(n, nb, block_size) for n, nb in zip(dims, occ.shape[::-1])]  # x, y, z
    # per world axis: where occupancy changes across a block boundary, as (z, y, x) indices with
    # the boundary's index (0 .. blocks) on that axis and block indices on the other two
    changes = {0: p[1:-1, 1:-1, 1:] != p[1:-1, 1:-1, :-1],
               1: p[1:-1, 1:, 1:-1] != p[1:-1, :-1, 1:-1],
               2: p[1:, 1:-1, 1:-1] != p[:-1, 1:-1, 1:-1]}
    out = []
    for axis, change in changes.items():
        z, y, x = np.nonzero(change)
        index = (x, y, z)  # per world axis: boundary index on `axis`, block index on the others
        u, v = (a for a in (0, 1, 2) if a != axis)
        corners = np.empty((len(x), 6, 3))
        corners[..., axis] = edges[axis][index[axis]][:, None]
        for column, other in ((0, u), (1, v)):
            low, high = edges[other][index[other]], edges[other][index[other] + 1]
            corners[..., other] = np.where(_QUAD[None, :, column] == 0, low[:, None], high[:, None])
        rows = np.empty((len(x), 6, 5))
        rows[..., :3] = origin + corners * spacing
        rows[..., 3] = axis
        rows[..., 4] = origin[axis] + corners[..., axis] * spacing[axis]
        out.append(rows.reshape(-1, 5))
    return np.concatenate(out).astype(np.float32)


def block_boxes(occ: np.ndarray, block_size: int, dims, spacing, origin) -> tuple[np.ndarray, np.ndarray]:
    """World boxes ``(lo, hi)``, each ``(K, 3)``, of the non-empty blocks."""
    spacing, origin = np.asarray(spacing, np.float64), np.asarray(origin, np.float64)
    z, y, x = np.nonzero(occ)
    edges = [block_edges(n, nb, block_size) for n, nb in zip(dims, occ.shape[::-1])]
    lo = origin + np.stack([edges[0][x], edges[1][y], edges[2][z]], axis=1) * spacing
    hi = origin + np.stack([edges[0][x + 1], edges[1][y + 1], edges[2][z + 1]], axis=1) * spacing
    return lo, hi


def clip_depths(boxes: tuple[np.ndarray, np.ndarray], camera, box) -> tuple[float, float] | None:
    """Near and far depths (along the camera's forward axis) to draw the faces between: every
    non-empty block (``boxes``: :func:`block_boxes`) lies between them, so no face is clipped.  None
    where a non-empty block reaches the camera's near plane (the eye is in or next to one): a ray may
    start inside it with its entry face behind the near plane, and the rays are not bounded."""
    lo, hi = boxes
    forward, eye = camera.basis()[0], np.asarray(camera.eye, np.float64)
    nearest = np.where(forward >= 0.0, lo, hi)  # per box, the corner forward points away from
    least = float(((nearest - eye) @ forward).min()) if len(lo) else np.inf
    box_lo, box_hi = (np.asarray(b, np.float64) for b in box)
    _, far = depth_range(camera, box_lo, box_hi)
    # margins of a thousandth of the near distance and a millionth of the volume: the GL clips in float32
    margin = 1e-3 * max(camera.near, 0.0) + 1e-6 * float(np.linalg.norm(box_hi - box_lo))
    # a perspective projection squeezes depths nearer than ~1e-3 of the scene against the far plane
    # (dvr_gl.gl.geometry.clip_planes): data that near the eye is not bounded either
    if not least > max(camera.near + margin, 2e-3 * float(np.linalg.norm(box_hi - box_lo))):
        return None
    near = max(camera.near, 0.5 * least)  # a perspective projection needs near > 0
    return near, max(far, near) * 1.01 + margin


class BoundsFaces:
    """The non-empty blocks' faces (:func:`boundary_faces`) in a vertex buffer, with a
    vertex array per program; ``count``: triangles' vertices."""

    def __init__(self, ctx, occ: np.ndarray, rows: np.ndarray, block_size: int, volume):
        self.setup(ctx, rows, block_boxes(occ, block_size, volume.dims, volume.spacing, volume.origin),
                   volume.box)

    def setup(self, ctx, rows: np.ndarray, boxes: tuple, box: tuple):
        """From the faces' rows, the non-empty blocks' world boxes ``(lo, hi)`` and the box the rays span
        (several fields: every member's faces and blocks, the union box)."""
        self.ctx, self.count = ctx, len(rows)
        self.buffer = ctx.buffer(rows.tobytes()) if self.count else None
        self._arrays = {}
        self._boxes = boxes
        self._box = box
        self._planes = None  # (camera, depth range) of the last frame

    @classmethod
    def of(cls, ctx, rows: np.ndarray, boxes: tuple, box: tuple) -> "BoundsFaces":
        faces = cls.__new__(cls)
        faces.setup(ctx, rows, boxes, box)
        return faces

    def vertex_array(self, program):
        if program not in self._arrays:
            self._arrays[program] = self.ctx.vertex_array(program, [(self.buffer, "3f 2f", "in_position",
                                                                     "in_plane")])
        return self._arrays[program]

    def clip_depths(self, camera) -> tuple[float, float] | None:
        """:func:`.clip_depths` for this camera (cached for the last one)."""
        if self._planes is None or self._planes[0] is not camera:
            self._planes = (camera, clip_depths(self._boxes, camera, self._box))
        return self._planes[1]

    def release(self):
        for array in self._arrays.values():
            array.release()
        if self.buffer is not None:
            self.buffer.release()


def box_rectangle(scene, box=None, defines=()) -> tuple[int, int, int, int] | None:
    """A pass's scissor box (x, y, w, h, rows from the bottom): the pixels whose rays can meet ``box`` (``(lo, hi)``,
    world; default the field's box: a one-pass frame's, the resolve's), or None where every pixel is drawn: the
    rectangle is the whole image or cannot be told, or the pass writes a depth image (``"DEPTH" in defines``), whose
    misses hold 3e38, not the clear's zero.  Outside it llvmpipe would still run the pass's code after the ray loop
    (the refinement, the resolve) for every block of pixels, masked but not skipped: with a thin slab small in a
    512x512 image a MIP frame's refinement took 2.8 ms where its loop took 0.3 (docs/peers.md, "A cheaper
    refinement")."""
    if "DEPTH" in defines:
        return None
    width, height = scene.image.width, scene.image.height
    rect = scene.camera.pixel_rectangle(box_corners(*(scene.field.box if box is None else box)), width, height)
    return None if rect is None or rect == (0, 0, width, height) else rect
