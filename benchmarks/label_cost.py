"""The cost of a label map beside its image in the default renderer of several fields (docs/labels.md, "Cost").

    python benchmarks/label_cost.py [--size 256] [--repeats 3] [--data-dir ../shared/data]

CThead (256 x 256 x 113, int16) with the ct-skin preset, shaded, and a bone label map on the same grid (a uint8
threshold of the smoothed CT, one label, opacity 0.9): the CT alone, the labels alone, the CT and the labels, and
for comparison the CT as two scalar channels.  Frames are timed interleaved (one warm-up frame each first), the
median of the repeats printed, with its ratio to the CT alone.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import dvr_gl
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import Member
from dvr_gl.renderers import create_renderer, registry

REPO = Path(__file__).resolve().parent.parent


def scenes(size: int, data_dir: Path) -> dict:
    ct = dvr_gl.io.load_volume(data_dir / "regular" / "cthead.nhdr")
    hu = ct.data.astype(np.float32) - 1024.0
    smooth = sum(np.roll(hu, s, axis=a) for a in range(3) for s in (-1, 0, 1)) / 9.0  # against speckle
    labels = (smooth > 400).astype(np.uint8)  # bone, by threshold (as several_fields_pictures.py's ct_labels)
    seg = Volume(labels, spacing=ct.spacing, origin=ct.origin, name="bone", direction=ct.direction)
    table = dvr_gl.labels.LabelTable.from_rows([[1, 0.25, 0.55, 1.0, 0.9]])
    keys = dict(size=size, up=(0, 0, -1), renderer=registry.default_for("fields"), shading=True)
    skin = dvr_gl.transfer_function.preset("ct-skin", ct.value_range, -1024.0)
    return {"CT": dvr_gl.scene_of(ct, transfer_function=skin, **keys),
            "labels": dvr_gl.scene_of([Member(seg, "label")], transfer_function=[table], **keys),
            "CT + labels": dvr_gl.scene_of([ct, Member(seg, "label")], transfer_function=[skin, table], **keys),
            "CT + CT": dvr_gl.scene_of([ct, ct], transfer_function=[skin, skin], **keys)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", nargs="*", help="scenes to time besides the CT alone (default: all)")
    ap.add_argument("--data-dir", type=Path, default=REPO.parent / "shared" / "data")
    args = ap.parse_args(argv)
    cases = scenes(args.size, args.data_dir)
    if args.only:
        cases = {name: scene for name, scene in cases.items() if name == "CT" or name in args.only}
    times = {name: [] for name in cases}
    with create_renderer(registry.default_for("fields")) as r:
        for scene in cases.values():
            r.render(scene)
        for _ in range(args.repeats):
            for name, scene in cases.items():
                start = time.perf_counter()
                r.render(scene)
                times[name].append(time.perf_counter() - start)
    base = statistics.median(times["CT"])
    print(f"{'scene':<14}{'s/frame':>9}{'x CT':>7}")
    for name, t in times.items():
        print(f"{name:<14}{statistics.median(t):>9.3f}{statistics.median(t) / base:>7.2f}")


if __name__ == "__main__":
    main()
