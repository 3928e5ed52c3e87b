"""``dvr bench shearwarp``: run-length encoding and compositing on real data, against the GPU ray caster.

For each dataset, transfer functions that leave 50 %, 90 % and 99 % of the voxels
transparent (an opacity ramp that starts at that quantile of the data, pre-classified
as in Lacroute and Levoy, so a voxel is transparent exactly when its value is at or
below the quantile; ties in the data make the measured fraction differ a little):

* the transparent fraction measured in the encoding, and the encoding's size;
* the time to build the run-length encodings of all three principal axes (once per
  transfer function);
* the shear-warp frame time (median of ``repeat`` frames after a warm-up that builds
  the encoding it uses): host compositing plus the GL warp and read-back, and the
  fraction of voxels never read (transparent runs and pieces of runs behind opaque
  pixels);
* the GPU ray caster's frame time on the same scene (same image size, half-voxel
  steps, pre-classified, early termination and empty-space skipping on);
* what shading costs: the time to encode every voxel's normal (once per volume), and the
  shaded frame (Blinn-Phong, the default headlight, by the frame's table over the normal
  codes; median alike, after a warm-up that builds its encoding).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from ....bench import median_seconds
from ....bench.picks import baseline
from ....scene.resolve import load_scene
from ... import create_renderer
from ..run_length import RunLengthVolume, SliceClassifier
from ..shading import VoxelNormals

DATASETS = [  # name, file under the data folder, scene overrides
    ("CThead", "regular/cthead.nhdr", {"camera.up": [0, 0, -1]}),
    ("lobster", "regular/lobster.nhdr", {}),
    ("CT bunny", "large/bunny_ct.nhdr", {}),
]
TRANSPARENT = (0.5, 0.9, 0.99)
COLUMNS = [("dataset", "dataset", ""), ("target", "transparent target", ".0%"),
           ("transparent", "transparent", ".1%"), ("rle_mb", "RLE MB (3 axes)", ".0f"),
           ("build_s", "RLE build s (3 axes)", ".2f"), ("ms", "shear-warp frame ms", ".0f"),
           ("skipped", "voxels skipped", ".1%"), ("raycast_ms", "raycast frame ms", ".0f"),
           ("normals_s", "normals s (once)", ".2f"), ("shaded_ms", "shaded frame ms", ".0f")]


def ramp(data: np.ndarray, fraction: float) -> list[list[float]]:
    """Transfer-function points: transparent up to the ``fraction`` quantile, then an opacity ramp."""
    lo, hi = float(data.min()), float(data.max())
    start = float(np.quantile(data, fraction))
    start = min(start, hi - 1e-6 * max(hi - lo, 1.0))
    return [[lo, 1.0, 0.9, 0.8, 0.0], [start, 1.0, 0.9, 0.8, 0.0], [hi, 0.9, 0.5, 0.3, 0.6]]


def run(data_dir: Path, size: int = 512, repeat: int = 5, datasets=DATASETS, fractions=TRANSPARENT):
    """Rows for the table, and notes (datasets not found)."""
    rows, notes = [], []
    with create_renderer("shearwarp") as shearwarp, create_renderer(baseline()) as raycast:
        for name, path, overrides in datasets:
            if not (data_dir / path).exists():
                notes.append(f"{name}: {data_dir / path} not found, skipped")
                continue
            volume = None
            for fraction in fractions:
                base = {"volume.path": str(data_dir / path), "image.width": size, "image.height": size,
                        "renderer.classification": "pre", **overrides}
                if volume is None:
                    volume = load_scene(None, base).volume
                base["transfer_function.points"] = ramp(volume.data, fraction)
                scene = load_scene(None, base).replace(volume=volume)
                encodings = [RunLengthVolume(volume.data, axis, SliceClassifier(
                    scene.transfer_function, "pre", scene.renderer.lut_size, 0.0)) for axis in range(3)]
                ms = 1e3 * median_seconds(shearwarp, scene, repeat)
                stats = dict(shearwarp.stats)
                raycast_ms = 1e3 * median_seconds(raycast, scene.with_renderer(name=raycast.name), repeat)
                start = time.perf_counter()
                VoxelNormals(volume, None)
                normals_s = time.perf_counter() - start
                shaded = scene.with_renderer(shading=dataclasses.replace(scene.renderer.shading, enabled=True))
                shaded_ms = 1e3 * median_seconds(shearwarp, shaded, repeat)
                rows.append({"dataset": name, "target": fraction,
                             "transparent": 1.0 - stats["stored_voxels"] / stats["voxels"],
                             "rle_mb": sum(e.nbytes for e in encodings) / 2 ** 20,
                             "build_s": sum(e.seconds for e in encodings), "ms": ms,
                             "skipped": stats["skipped_fraction"], "raycast_ms": raycast_ms,
                             "normals_s": normals_s, "shaded_ms": shaded_ms})
    return rows, notes
