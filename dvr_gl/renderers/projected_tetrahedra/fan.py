"""Shirley and Tuchman's fan built on the host: the ``shirley-tuchman`` integration without the
geometry shader.

``pt.geom`` builds each cell's fan per frame in the geometry stage, which llvmpipe runs on the
calling thread.  Here :mod:`.fan_compiled` (numba, the optional extra ``numba``) builds the same fan
in float64 (the silhouette's class, the thick vertex, the exact integral along the thick piece, the
corners' colours) into a vertex buffer in visibility order, drawn with ``pt_fan.vert`` and the same
``pt_st.frag``.  Where numba is not installed :func:`compiled` is ``None`` and the renderer draws
the fan in ``pt.geom``; both give the same picture within float32 rounding
(``test_the_host_fan_equals_the_geometry_shaders_fan``).
"""

from __future__ import annotations

import functools
import importlib

import numpy as np

from ...reference.converged import collocation
from ..mesh.textures import interval_sigma_max


def compiled():
    """:mod:`.fan_compiled` (numba) when numba is installed, else ``None`` (the fan in ``pt.geom``)."""
    try:
        return importlib.import_module(".fan_compiled", __package__)
    except ImportError:
        return None


@functools.cache
def _gauss_legendre() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 4-point Gauss-Legendre rule on [0, 1] in float64: nodes, weights, spectral integration
    matrix (``S[i, j]``: the integral from 0 to node i of the Lagrange basis l_j)."""
    x, w, s = collocation(4)
    return 0.5 * (x + 1.0), 0.5 * w, np.ascontiguousarray(0.5 * s)


class HostFan:
    """One mesh's fan on the host: the points relative to ``centre`` (as the textures hold them), the
    cells, each cell's scalar ``g . p + c``, and the vertex and index buffers (the index buffer fixed:
    four triangles around each cell's thick vertex), kept per mesh."""

    def __init__(self, ctx, mesh, centre, fast):
        self.fast, self.centre = fast, np.asarray(centre, np.float64)
        rec = mesh.reconstruct()
        self.points = np.ascontiguousarray(mesh.points - centre, dtype=np.float64)
        self.tets = np.ascontiguousarray(mesh.tets, dtype=np.int64)
        self.gradients = np.ascontiguousarray(rec.gradients, dtype=np.float64)
        self.offsets = np.ascontiguousarray(rec.base - np.einsum("ij,ij->i", rec.gradients, rec.anchor - centre))
        cells = len(self.tets)
        self.out = np.empty((fast.CELL_VERTICES * cells, fast.VERTEX_FLOATS), np.float32)
        self.vertices = ctx.buffer(reserve=max(self.out.nbytes, 4))
        base = fast.CELL_VERTICES * np.arange(cells, dtype=np.uint32)[:, None]
        fan = np.array([0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1], np.uint32)
        self.indices = ctx.buffer((base + fan).astype(np.uint32).tobytes() if cells else b"\0\0\0\0")

    def build(self, scene, order: np.ndarray, view_projection: np.ndarray) -> int:
        """Write the fan of ``order``'s cells (drawn in that order) into the vertex buffer; the indices to
        draw (12 a cell)."""
        fast, cam, img, tf = self.fast, scene.camera, scene.image, scene.transfer_function
        projected = fast.project(self.points, np.ascontiguousarray(view_projection, np.float64),
                                 float(img.width), float(img.height))
        forward, _, _ = cam.basis()
        perspective = cam.projection == "perspective"
        eye = np.asarray(cam.eye, np.float64) - self.centre
        x, w, s = _gauss_legendre()
        n = len(order)
        out = self.out[:fast.CELL_VERTICES * n]
        fast.fan(np.ascontiguousarray(order, np.int64), self.tets, self.points, projected, self.gradients,
                 self.offsets, eye, np.asarray(forward, np.float64), perspective,
                 np.ascontiguousarray(tf.points[:, :5], np.float64), interval_sigma_max(tf).astype(np.float64),
                 tf.opacity_model == "alpha", float(tf.unit_distance), x, w, s, out)
        self.vertices.write(out)
        return fast.CELL_INDICES * n

    def release(self):
        self.vertices.release()
        self.indices.release()
