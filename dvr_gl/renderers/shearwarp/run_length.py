"""Run-length encoded classified volumes for shear-warp (Lacroute and Levoy 1994).

For a principal axis ``c`` the volume is read as slices ``k`` across ``c``, each
a 2D image ``[j, i]`` (permuted coordinates, :mod:`.factorization`).  Every
voxel scanline ``(k, j)`` is stored as pairs of runs, a run of transparent
voxels then a run of non-transparent ones, the last pair closing the scanline
(its non-transparent run may be empty), so a scanline's pairs add up to ``Ni``.
The non-transparent voxels' data (the *payload*) is stored densely in scanline
order; transparent voxels cost nothing but their run's length.

Transparency depends on the transfer function, so an encoding is built when it
changes and reused for every view along that axis:

* pre-classification: the payload is ``(sigma c, sigma)`` per voxel (emission
  and extinction, the conventions' associated colours); a voxel is transparent
  when its extinction is at most the threshold's;
* post-classification: the payload is the scalar; a voxel is transparent when no
  value that bilinear interpolation can produce in the four in-slice cells around
  it (the range of its 3x3 neighbourhood) has extinction above the threshold's, in
  the table the renderer classifies with.  Then a sample whose four voxels are not
  all stored is no more opaque than the threshold, and the compositor drops it.

The threshold is ``opacity_threshold``, an opacity over one ``unit_distance``;
with 0 (the default) exactly the invisible voxels are skipped and the image is
unchanged.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .factorization import permuted_axes


def permuted_slice(data: np.ndarray, axis: int, k: int) -> np.ndarray:
    """Slice ``k`` across world ``axis`` of ``data[z, y, x]`` as ``[j, i]`` (i along ``(axis + 1) % 3``)."""
    if axis == 2:
        return data[k]
    if axis == 0:
        return data[:, :, k]
    return data[:, k, :].T


def encode_scanlines(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run pairs ``(transparent, non-transparent)`` of every row of a ``(Nj, Ni)`` mask, rows in order."""
    nj, ni = mask.shape
    padded = np.zeros((nj, ni + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    edges = np.diff(padded, axis=1)
    run_rows, run_starts = np.nonzero(edges == 1)
    _, run_ends = np.nonzero(edges == -1)  # row-major order pairs them with the starts
    rows = np.concatenate([run_rows, np.arange(nj)])  # each row closes with an empty run at Ni
    starts = np.concatenate([run_starts, np.full(nj, ni)])
    ends = np.concatenate([run_ends, np.full(nj, ni)])
    order = np.lexsort((starts, rows))
    rows, starts, ends = rows[order], starts[order], ends[order]
    previous_end = np.concatenate([[0], ends[:-1]])
    previous_end[np.concatenate([[True], rows[1:] != rows[:-1]])] = 0
    return (starts - previous_end).astype(np.int32), (ends - starts).astype(np.int32)


class SliceClassifier:
    """What a slice stores: the payload per voxel and which voxels are transparent."""

    def __init__(self, transfer_function, classification: str, lut_size: int, opacity_threshold: float):
        self.tf = transfer_function
        self.classification = classification
        self.sigma_threshold = -math.log1p(-opacity_threshold) / transfer_function.unit_distance
        self.channels = 4 if classification == "pre" else 1
        if classification == "post":
            self.lut = transfer_function.tabulate(lut_size)
            # the table is linear between nodes, so values between nodes i0 and i1 reach extinction above
            # the threshold exactly when a node in i0 .. i1 does: the first such node at or after i0
            nodes = np.arange(self.lut.size)
            above = np.where(self.lut.table[:, 3] > self.sigma_threshold, nodes, self.lut.size)
            self.next_visible_node = np.minimum.accumulate(above[::-1])[::-1]

    def __call__(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(payload (Nj, Ni, C) float32, visible (Nj, Ni) bool)`` of a slice."""
        if self.classification == "pre":
            classified = self.tf.classify_voxels(values, associated=True)
            return classified.astype(np.float32), classified[..., 3] > self.sigma_threshold
        lo, hi = _neighbourhood_range(values.astype(np.float64))
        i0 = np.floor(self.lut.node_coordinate(lo)).astype(np.int64)
        i1 = np.minimum(np.ceil(self.lut.node_coordinate(hi)).astype(np.int64), self.lut.size - 1)
        visible = self.next_visible_node[i0] <= i1
        return values.astype(np.float32)[..., None], visible


def _neighbourhood_range(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimum and maximum over each voxel's 3x3 in-slice neighbourhood (clamped at the edges),
    separably: across rows, then across columns."""
    def window(a, op, axis):
        padded = np.pad(a, [(1, 1) if ax == axis else (0, 0) for ax in range(2)], mode="edge")
        n = a.shape[axis]
        parts = [padded[d:d + n] if axis == 0 else padded[:, d:d + n] for d in range(3)]
        return op(op(parts[0], parts[1]), parts[2])

    return (window(window(values, np.minimum, 0), np.minimum, 1),
            window(window(values, np.maximum, 0), np.maximum, 1))


class RunLengthVolume:
    """One principal axis's encoding: run pairs and payload, slice by slice.

    Attributes:
        axis: the world axis the slices are taken across.
        dims: permuted ``(Ni, Nj, Nk)``.
        transparent, visible: run lengths of the pairs, all slices concatenated.
        pair_offset: ``(Nk + 1,)`` index of each slice's first pair.
        payload: ``(voxels stored, C)`` float32; ``payload_offset``: each slice's first row.
        lut: post-classification's transfer-function table (None for pre-classified payloads).
        codes, factor: with ``normals`` (:class:`.shading.VoxelNormals`), the stored voxels' normal
            codes and (with gradient opacity) factors, row for row with the payload; else None.
        seconds: the time the encoding took.
    """

    def __init__(self, data: np.ndarray, axis: int, classify: SliceClassifier, normals=None):
        start = time.perf_counter()
        a, b, c = permuted_axes(axis)
        shape_xyz = data.shape[::-1]
        self.axis = axis
        self.dims = (shape_xyz[a], shape_xyz[b], shape_xyz[c])
        self.lut = getattr(classify, "lut", None)  # post-classification: the table samples are classified by
        transparent, visible, payload, codes, factor = [], [], [], [], []
        for k in range(self.dims[2]):
            values, mask = classify(permuted_slice(data, axis, k))
            t, v = encode_scanlines(mask)
            transparent.append(t)
            visible.append(v)
            payload.append(values[mask])
            if normals is not None:
                codes.append(permuted_slice(normals.codes, axis, k)[mask])
            if normals is not None and normals.factor is not None:
                factor.append(permuted_slice(normals.factor, axis, k)[mask])
        self.codes = np.concatenate(codes) if codes else None
        self.factor = np.concatenate(factor) if factor else None
        self.transparent = np.concatenate(transparent)
        self.visible = np.concatenate(visible)
        self.pair_offset = np.concatenate([[0], np.cumsum([len(t) for t in transparent])])
        self.payload = np.concatenate(payload) if payload else np.zeros((0, classify.channels), np.float32)
        self.payload_offset = np.concatenate([[0], np.cumsum([len(p) for p in payload])])
        self.seconds = time.perf_counter() - start

    @property
    def stored_voxels(self) -> int:
        return len(self.payload)

    @property
    def nbytes(self) -> int:
        """Memory held: runs, offsets and payload."""
        return sum(a.nbytes for a in (self.transparent, self.visible, self.pair_offset, self.payload,
                                      self.payload_offset, self.codes, self.factor) if a is not None)

    def runs(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Slice ``k``'s non-transparent runs: first voxel (flat ``j Ni + i``), length, first payload row."""
        lo, hi = self.pair_offset[k], self.pair_offset[k + 1]
        t, v = self.transparent[lo:hi].astype(np.int64), self.visible[lo:hi].astype(np.int64)
        pair_start = np.cumsum(t + v) - (t + v)
        keep = v > 0
        length = v[keep]
        first_row = self.payload_offset[k] + np.cumsum(length) - length
        return (pair_start + t)[keep], length, first_row


def expand_runs(first: np.ndarray, length: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(index within each run, run number)`` of every voxel of the runs, in order."""
    total = int(length.sum())
    run = np.repeat(np.arange(len(length)), length)
    offset = np.arange(total) - np.repeat(np.cumsum(length) - length, length)
    return offset, run
