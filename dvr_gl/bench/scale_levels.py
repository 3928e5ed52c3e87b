"""``dvr bench scale --part levels``: what each pyramid level costs and loses.

Two tables.  The downsampling kernels (:data:`dvr_gl.multires.KERNELS`) on the Marschner-Lobb signal:
how much of a frequency above the coarse grid's Nyquist survives (and aliases), how much of one below
it is kept, the box a level keeps, and the RMS error of levels 1 and 2, reconstructed trilinearly, against
the analytic signal at random points of the box.  Then the levels of the demos and of the shared
datasets (skipped, with the reason, where the folder is absent): dims, bytes, the projected voxel size
at the scene's view, and the rendered error against the full resolution
(:func:`dvr_gl.multires.level_errors`), with the float64 reference beside the GPU ray caster on the
small demo.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..multires import KERNELS, build_levels, level_errors
from ..multires.downsample import TENT
from . import Report, picks, tick
from .datasets import STUDIES

ML_F_M, ML_ALPHA = 6.0, 0.25  # the Marschner-Lobb parameters of dvr_gl.phantoms
# name, file under the data folder, scene overrides: three of dvr bench accel's
DATASETS = [d for name in ("CThead, skin", "lobster, shell", "hydrogen, narrow shell") for d in STUDIES if d[0] == name]
DEMOS = ("blobs", "marschner-lobb")
KERNEL_COLUMNS = [("kernel", "kernel", ""), ("alias", "kept at 0.375 (aliases)", ".3f"),
                  ("pass", "kept at 0.125", ".3f"), ("box", "level box vs level 0's", ""),
                  ("rms1", "RMS level 1", ".4f"), ("rms2", "RMS level 2", ".4f"),
                  ("image1", "image RMS level 1", ".4f")]
COLUMNS = [("case", "case", ""), ("level", "level", "d"), ("dims", "dims", ""), ("spacing", "spacing", ""),
           ("bytes", "bytes", ","), ("voxel_px", "voxel px", ".2f"), ("rms", "RMS vs full", ".4f"),
           ("max", "max vs full", ".3f"), ("predicted", "predicted RMS", ".4f"),
           ("judged", "RMS float64 ref.", ".4f")]


def marschner_lobb(points: np.ndarray) -> np.ndarray:
    """The analytic Marschner-Lobb signal at phantom coordinates ``(..., 3)`` in [-1, 1]^3 (the formula of
    :func:`dvr_gl.phantoms.marschner_lobb`)."""
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    rho = np.cos(2.0 * np.pi * ML_F_M * np.cos(np.pi * np.sqrt(x * x + y * y) / 2.0))
    return (1.0 - np.sin(np.pi * z / 2.0) + ML_ALPHA * (1.0 + rho)) / (2.0 * (1.0 + ML_ALPHA))


def kernel_rows(size: int = 64, points: int = 20000, image: int = 128, seed: int = 1) -> list[dict]:
    """Each kernel on the Marschner-Lobb demo of ``size^3``: the columns of :data:`KERNEL_COLUMNS`."""
    from ..phantoms import demo_scene, demo_volume
    from ..scene.resolve import load_scene

    volume = demo_volume("marschner-lobb", size)
    half = (size - 1) / 2.0
    lo, hi = volume.box
    rng = np.random.default_rng(seed)
    world = lo + (hi - lo) * rng.random((points, 3))
    truth = marschner_lobb(world / half)
    scene = load_scene(None, {"volume.size": size, "image.width": image, "image.height": image},
                       demo_scene("marschner-lobb"))
    rows = []
    for kernel in KERNELS.values():
        levels = build_levels(volume, 2, kernel)
        errors = [float(np.sqrt(np.mean((level.reconstruct("linear").sample(world) - truth) ** 2)))
                  for level in levels]
        lo1, hi1 = levels[0].box
        grow = np.concatenate([lo - lo1, hi1 - hi]) / np.array(volume.spacing * 2)  # fine voxels, >0: covered
        box = "the same" if np.allclose(grow, 0) else (
            f"covers, +{grow.max():g} fine voxel at the high end" if grow.min() >= 0 else
            f"shrinks by {-grow.min():g} fine voxel a side")
        image_rms = level_errors(scene, (volume, levels[0]))[1]["rms"]
        tick()
        rows.append({"kernel": kernel.name, "alias": kernel.response(0.375), "pass": kernel.response(0.125),
                     "box": box, "rms1": errors[0], "rms2": errors[1], "image1": image_rms})
    return rows


DATA_KERNEL_COLUMNS = [("case", "case", ""), ("kernel", "kernel", ""), ("full1", "level 1 vs full", ".4f"),
                       ("full2", "level 2 vs full", ".4f"), ("aa0", "level 0 vs AA", ".4f"),
                       ("aa1", "level 1 vs AA", ".4f"), ("aa2", "level 2 vs AA", ".4f")]
SUPERSAMPLE = 4  # rays per pixel along each axis of the anti-aliased image


def data_kernel_rows(cases, size: int) -> list[dict]:
    """Each kernel's levels 1 and 2 on each ``(name, overrides)`` case, image RMS against level 0's image
    and against an anti-aliased one (level 0 at :data:`SUPERSAMPLE` times the size, averaged down): what
    a level loses in a still picture, beside what one ray per pixel of the full data loses itself."""
    from ..multires.accuracy import level_scene
    from ..renderers import create_renderer
    from ..scene.resolve import load_scene

    rows, f = [], SUPERSAMPLE
    with create_renderer(picks.baseline()) as r:
        for name, overrides in cases:
            scene = load_scene(None, {"image.width": size, "image.height": size, **overrides})
            big = load_scene(None, {"image.width": size * f, "image.height": size * f, **overrides})
            smooth = np.asarray(r.render(big), np.float64).reshape(size, f, size, f, 4).mean(axis=(1, 3))
            full = np.asarray(r.render(scene), np.float64)
            tick()
            for kernel in KERNELS.values():
                row = {"case": name, "kernel": kernel.key, "aa0": _rms(full, smooth)}
                for index, level in enumerate(build_levels(scene.field, 2, kernel), 1):
                    image = np.asarray(r.render(level_scene(scene, level)), np.float64)
                    row[f"full{index}"], row[f"aa{index}"] = _rms(image, full), _rms(image, smooth)
                    tick()
                rows.append(row)
    return rows


def _rms(a, b) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def level_rows(case: str, scene, reference: bool = False, count: int | None = None) -> list[dict]:
    """The levels of ``scene``'s volume (:func:`~dvr_gl.multires.build_levels`, ``count`` of them) and their
    errors."""
    levels = (scene.field, *build_levels(scene.field, count))
    rows = level_errors(scene, levels)
    tick()
    if reference:
        for row, ref in zip(rows, level_errors(scene, levels, renderer=picks.discrete())):
            row["judged"] = ref["rms"]  # the same-discretization judge: the model's error, not the GPU's
    for row, level in zip(rows, levels):
        row["case"] = case
        row["spacing"] = ", ".join(f"{s:g}" for s in level.spacing)
    return rows


def run(args) -> int:
    """Print the two tables (``args``: ``size``, the image side; ``data_dir``, the shared datasets;
    ``report``, a :class:`~dvr_gl.bench.Report`; all optional)."""
    from ..phantoms import demo_scene
    from ..scene.resolve import load_scene

    size = int(getattr(args, "size", None) or 256)
    report = getattr(args, "report", None) or Report()
    report.text(f"Downsampling kernels on the Marschner-Lobb demo (64^3): the response (0..1) at 0.375 cycles per "
                f"fine voxel, above the coarse Nyquist 0.25 (what survives there aliases), and at 0.125 (kept "
                f"detail); the RMS error of levels 1 and 2, trilinearly reconstructed, against the analytic signal "
                f"at 20000 random points of the box; the RMS error of level 1's image (128x128, the demo's "
                f"view) against level 0's.  The pyramid uses {TENT.name}.")
    report.table(kernel_rows(), KERNEL_COLUMNS)
    data_dir = Path(getattr(args, "data_dir", None) or "../shared/data")
    rows, notes = [], []
    for name in DEMOS:
        overrides = {"image.width": size, "image.height": size}
        rows += level_rows(f"{name} 64^3", load_scene(None, overrides, demo_scene(name)))
    small = {"volume.size": 32, "image.width": 48, "image.height": 48}
    rows += level_rows("blobs 32^3, 48x48", load_scene(None, small, demo_scene("blobs")), reference=True,
                       count=2)
    if not data_dir.is_dir():
        notes.append(f"shared datasets skipped: {data_dir} is not a folder (pass --data-dir)")
    else:
        for name, path, overrides in DATASETS:
            if not (data_dir / path).exists():
                notes.append(f"{name} skipped: {data_dir / path} is missing")
                continue
            scene = load_scene(None, {"volume.path": str(data_dir / path), "image.width": size,
                                      "image.height": size, **overrides})
            rows += level_rows(name, scene)
    cases = [(name, {"volume.path": str(data_dir / path), **overrides}) for name, path, overrides in DATASETS
             if (data_dir / path).exists()]
    if cases:
        report.text()
        report.text(f"The kernels on the shared datasets, {size}x{size} at each scene's default view: image RMS of "
                    f"levels 1 and 2 against level 0's image, and against level 0 anti-aliased ({SUPERSAMPLE}x"
                    f"{SUPERSAMPLE} rays a pixel, averaged; 'level 0 vs AA' is what one ray a pixel of the full "
                    f"data loses itself).")
        report.table(data_kernel_rows(cases, size), DATA_KERNEL_COLUMNS)
    report.text()
    report.text(f"Levels (tent kernel, down to {32} samples a side) rendered whole by the GPU ray caster at each "
                f"scene's default view, {size}x{size} (the small blobs case also by the float64 reference), sample "
                f"distance in world units kept; RMS and max over premultiplied RGBA against level 0's image; "
                f"'voxel px': one voxel (largest spacing) projected at the box's nearest point; 'predicted RMS': "
                f"level 1's RMS times the voxel size relative to level 1's.")
    report.table(rows, COLUMNS, notes)
    return 0
