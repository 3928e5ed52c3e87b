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
from concurrent.futures import ThreadPoolExecutor

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
    cells, each cell's scalar ``g . p + c``, the vertex rows (five a cell, by cell) and the triangles'
    indices (twelve a cell, in visibility order), and their GL buffers, kept per mesh.  A frame
    :meth:`start` builds the fan's vertices in a thread of its own (numba without the GIL) while the
    renderer computes the order, and :meth:`finish` indexes them in that order."""

    def __init__(self, ctx, mesh, centre, fast):
        self.fast, self.centre = fast, np.asarray(centre, np.float64)
        rec = mesh.reconstruct()
        self.points = np.ascontiguousarray(mesh.points - centre, dtype=np.float64)
        self.tets = np.ascontiguousarray(mesh.tets, dtype=np.int64)
        self.gradients = np.ascontiguousarray(rec.gradients, dtype=np.float64)
        self.offsets = np.ascontiguousarray(rec.base - np.einsum("ij,ij->i", rec.gradients, rec.anchor - centre))
        cells = len(self.tets)
        self.rows = np.zeros((fast.CELL_VERTICES * cells, fast.VERTEX_FLOATS), np.float32)
        self.triangles = np.zeros(fast.CELL_INDICES * cells, np.uint32)
        self.vertices = ctx.buffer(reserve=max(self.rows.nbytes, 4))
        self.indices = ctx.buffer(reserve=max(self.triangles.nbytes, 4))
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pt-fan")
        self._pending = None

    def start(self, scene, view_projection: np.ndarray, drawn: np.ndarray):
        """Begin building the fan of the cells with ``drawn`` for this view (``view_projection``: centre-
        relative points to clip coordinates, float64)."""
        fast, cam, img, tf = self.fast, scene.camera, scene.image, scene.transfer_function
        forward, _, _ = cam.basis()
        x, w, s = _gauss_legendre()
        drawn = np.ascontiguousarray(drawn, np.bool_)
        view = (np.asarray(cam.eye, np.float64) - self.centre, np.asarray(forward, np.float64),
                cam.projection == "perspective")
        classes = (np.ascontiguousarray(tf.points[:, :5], np.float64), interval_sigma_max(tf).astype(np.float64),
                   tf.opacity_model == "alpha", float(tf.unit_distance))

        def build():
            projected = fast.project(self.points, np.ascontiguousarray(view_projection, np.float64),
                                     float(img.width), float(img.height))
            fast.fan(drawn, self.tets, self.points, projected, self.gradients, self.offsets, *view, *classes,
                     x, w, s, self.rows)

        self._pending = self._worker.submit(build)

    def finish(self, order: np.ndarray) -> int:
        """Wait for the fan, index its triangles in ``order`` (the cells drawn, back to front), upload
        both; the indices to draw (12 a cell)."""
        self._pending.result()
        n = self.fast.CELL_INDICES * len(order)
        self.fast.indices(np.ascontiguousarray(order, np.int64), self.triangles)
        self.vertices.write(self.rows)
        self.indices.write(self.triangles[:n])
        return n

    def release(self):
        self._worker.shutdown(wait=True)
        self.vertices.release()
        self.indices.release()
