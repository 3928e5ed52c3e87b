"""Pictures of several fields for docs/several-fields.md, by the default renderer of several fields (the registry's).

    python benchmarks/several_fields_pictures.py [--size 320] [--data-dir ../shared/data] [--out docs/images]

* ``fields-depth-order.png``: two channels that overlap on the screen at different depths (a magenta ball in
  front of a green one, the same grid), left to right: composited per sample (dvr-gl), the two channels rendered
  alone and added in screen space (napari's additive layer blending), and laid over each other in a fixed layer
  order (its translucent blending, the green layer on top: right only when seen from the other side).  The
  largest difference of each to the per-sample picture is printed.
* ``fields-nucleus.png``: the shared two-channel nucleus (``microscopy/xyzc_16bit__dna_conf_wf.tif``: confocal in
  magenta, widefield in green), emission-absorption and the per-channel MIP.
* ``fields-ct-labels.png``: CThead with a label map made from it (bone, by a threshold of the smoothed CT: a
  segmentation derived here, not a clinical one) as a second field: the CT alone, the label alone, both.
* ``fields-time.gif``: the shared dividing cell (``microscopy/CellDivision_..._TZCYX.tif``, 2 channels, 3 steps),
  one frame per time step, orbiting.

Frame times are printed (one frame after a first that builds textures).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import dvr_gl
from dvr_gl.bench.pictures import timed
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import Member
from dvr_gl.image import side_by_side, write_image
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.scene.resolve import load_scene

REPO = Path(__file__).resolve().parent.parent


def _over(front: np.ndarray, back: np.ndarray) -> np.ndarray:
    return front + (1.0 - front[..., 3:]) * back


def depth_order(size: int) -> tuple[np.ndarray, dict]:
    """Two balls of constant material on one 64^3 grid, apart in depth (no voxel holds both) but overlapping on
    the screen: the magenta one nearer the eye."""
    n, radius = 64, 12.0
    name = registry.default_for("fields")
    keys = dict(size=size, azimuth=20.0, elevation=15.0, renderer=name)
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32)
    probe = dvr_gl.scene_of(np.zeros((n, n, n), np.float32), **keys)
    forward, right, _ = (np.asarray(v, float) for v in probe.camera.basis())
    centre = np.full(3, (n - 1) / 2.0)
    balls = []
    for c in (centre - 14.0 * forward - 5.0 * right, centre + 14.0 * forward + 5.0 * right):  # front, back
        balls.append(((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 <= radius ** 2).astype(np.float32))
    tfs = [[[0, 1, 0, 1, 0], [1, 1, 0, 1, 0.35]], [[0, 0, 1, 0, 0], [1, 0, 1, 0, 0.35]]]
    both = dvr_gl.scene_of(balls, transfer_function=tfs, **keys)
    alone = [dvr_gl.scene_of(data, transfer_function=tf, camera=both.camera, **keys) for data, tf in zip(balls, tfs)]
    with create_renderer(name) as r:
        mixed = timed(r, both, "per sample")
        front, back = (timed(r, s, f"channel {k} alone") for k, s in enumerate(alone))
    added = np.clip(front + back, 0.0, 1.0)
    layered = _over(back, front)  # the layer order fixed (green over magenta): right only from the other side
    errors = {"added": float(np.abs(added - mixed).max()), "layered": float(np.abs(layered - mixed).max()),
              "in depth order": float(np.abs(_over(front, back) - mixed).max())}
    print("  largest difference to per sample: " + ", ".join(f"{k} {v:.3f}" for k, v in errors.items()))
    return side_by_side([mixed, added, layered]), errors


def nucleus(size: int, data_dir: Path) -> np.ndarray | None:
    path = data_dir / "microscopy" / "xyzc_16bit__dna_conf_wf.tif"
    if not path.exists():
        print(f"  {path} absent: skipped")
        return None
    pictures = []
    with create_renderer(registry.default_for("fields")) as r:
        for mode in ("emission_absorption", "mip"):
            scene = load_scene(None, {"volume.path": str(path), "image.width": size, "image.height": size,
                                      "camera.elevation": 25.0, "renderer.name": r.name,
                                      "renderer.compositing": mode})
            scene = scene.replace(camera=scene.camera.orbited(None, None, 0.45 * scene.camera.orbit[2]))
            pictures.append(timed(r, scene, f"nucleus, {mode}"))
    return side_by_side(pictures)


def ct_labels(size: int, data_dir: Path) -> np.ndarray | None:
    path = data_dir / "regular" / "cthead.nhdr"
    if not path.exists():
        print(f"  {path} absent: skipped")
        return None
    ct = dvr_gl.io.load_volume(path)
    hu = ct.data.astype(np.float32) - 1024.0
    smooth = sum(np.roll(hu, s, axis=a) for a in range(3) for s in (-1, 0, 1)) / 9.0  # against speckle
    labels = (smooth > 400).astype(np.uint8)  # bone, by threshold: a segmentation derived here
    seg = Volume(labels, spacing=ct.spacing, origin=ct.origin, name="bone", direction=ct.direction)
    table = dvr_gl.labels.LabelTable.from_rows([[1, 0.25, 0.55, 1.0, 0.9]])
    keys = dict(size=size, up=(0, 0, -1), renderer=registry.default_for("fields"), shading=True)
    skin = dvr_gl.transfer_function.preset("ct-skin", ct.value_range, -1024.0)
    scenes = [dvr_gl.scene_of(ct, transfer_function=skin, **keys),
              dvr_gl.scene_of([Member(seg, "label")], transfer_function=[table], **keys),
              dvr_gl.scene_of([ct, Member(seg, "label")], transfer_function=[skin, table], **keys)]
    with create_renderer(keys["renderer"]) as r:
        return side_by_side([timed(r, s, label) for s, label in zip(scenes, ("CT", "labels", "CT + labels"))])


def time_series(size: int, data_dir: Path, out: Path) -> None:
    path = data_dir / "microscopy" / "CellDivision_T3_Z5_CH2_X240_Y170_TZCYX.tif"
    if not path.exists():
        print(f"  {path} absent: skipped")
        return
    import subprocess
    import sys

    target = out / "fields-time.gif"
    if target.exists():
        target.unlink()
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "dvr_gl", "render", str(path), "-o", str(target), "--frames", "12",
                    "--animate", "time,orbit", "--fps", "4", "--size", str(size), "--elevation", "40"], check=True)
    print(f"  time series: 12 frames in {time.perf_counter() - start:.1f} s -> {target}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=320)
    ap.add_argument("--data-dir", type=Path, default=REPO.parent / "shared" / "data")
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    print("depth order:")
    picture, _ = depth_order(args.size)
    write_image(args.out / "fields-depth-order.png", picture, overwrite=True)
    print("nucleus:")
    picture = nucleus(args.size, args.data_dir)
    if picture is not None:
        write_image(args.out / "fields-nucleus.png", picture, overwrite=True)
    print("CT with labels:")
    picture = ct_labels(args.size, args.data_dir)
    if picture is not None:
        write_image(args.out / "fields-ct-labels.png", picture, overwrite=True)
    print("time series:")
    time_series(args.size // 2 * 2, args.data_dir, args.out)


if __name__ == "__main__":
    main()
