"""Pictures of a 2D transfer function (value x gradient magnitude) for docs/transfer-functions.md.

    python benchmarks/transfer_function_2d_pictures.py [--size 256] [--data-dir ../shared/data] [--out docs/images]

* ``transfer-function-2d.png``: CThead (from the shared data; else the Marschner-Lobb demo), shaded, left to
  right: the 1D ``ct-skin`` preset; two boxes over value and gradient magnitude, one on the boundary between air
  and skin (values between them, steep), one on the bone's surface; and the joint histogram of value (across) and
  gradient magnitude (up), log counts in grey, with the boxes' table over it.  By the first GL renderer that
  declares a 2D transfer function for grids (today the ray caster).

The frame times are printed: one frame each, after a first one that makes the textures.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dvr_gl.bench.pictures import head, timed
from dvr_gl.image import side_by_side, write_image
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.transfer_function_2d import TransferFunction2D, histogram_2d

REPO = Path(__file__).resolve().parents[1]
#: CThead's data values are HU + 1024: air up to about 300, soft tissue 900 to 1100, bone from about 1300;
#: the boundary between air and skin has the values between and gradient magnitudes of 150 and more per mm
BOXES = [[300.0, 100.0, 600.0, 800.0, 0.95, 0.45, 0.35, 0.06], [1300.0, 250.0, 1400.0, 650.0, 1.0, 0.95, 0.85, 0.9]]


def histogram_picture(data, spacing, tf: TransferFunction2D, size: int) -> np.ndarray:
    """The joint histogram (log counts, grey; value across, gradient magnitude up) with the table over it, as a
    premultiplied ``size x size`` picture."""
    counts, _, _ = histogram_2d(data, spacing, bins=tf.shape, value_range=tf.value_range,
                                gradient_range=tf.gradient_range)
    grey = np.sqrt(np.log1p(counts) / max(np.log1p(counts).max(), 1e-30))
    table = tf.table
    alpha = np.clip(table[..., 3:4] * 4.0, 0.0, 0.8)  # the boxes' opacity, made visible over the grey
    rgb = table[..., :3] * alpha + grey[..., None] * 0.8 * (1.0 - alpha)
    picture = np.concatenate([rgb, np.ones_like(alpha)], axis=-1).transpose(1, 0, 2)[::-1]  # rows: gradient, up
    rows = np.minimum(np.arange(size) * picture.shape[0] // size, picture.shape[0] - 1)
    cols = np.minimum(np.arange(size) * picture.shape[1] // size, picture.shape[1] - 1)
    return picture[rows][:, cols].astype(np.float32)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    scene, label = head(args.size, Path(args.data_dir), "ct-skin")
    volume = scene.volume
    tf = TransferFunction2D.from_boxes(BOXES, (0.0, 3000.0), (0.0, 900.0), size=(256, 128))
    if label != "CThead":  # the demo's values: boxes over its own range
        lo, hi = volume.value_range
        tf = TransferFunction2D.from_boxes([[lo + 0.3 * (hi - lo), 0.0, 0.4 * (hi - lo), 2.0 * (hi - lo), 0.9, 0.55,
                                             0.4, 0.6]], (lo, hi), (0.0, 2.0 * (hi - lo)))
    name = registry.renderers_with(lambda q: q.needs_gl and "grid" in q.transfer_function_2d)[0]
    renderer = create_renderer(name)
    try:
        print(f"{label}, {name}:")
        one = timed(renderer, scene.with_renderer(name=name), "1D (ct-skin)")
        two = timed(renderer, scene.with_renderer(name=name).replace(transfer_function=tf), "2D (two boxes)")
    finally:
        renderer.close()
    histogram = histogram_picture(volume.data, volume.spacing, tf, args.size)
    out = Path(args.out)
    write_image(out / "transfer-function-2d.png", side_by_side([one, two, histogram]), overwrite=True)
    print(f"wrote transfer-function-2d.png in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
