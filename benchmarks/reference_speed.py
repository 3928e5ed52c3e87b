"""Speed of the CPU references: a 128x128 image of a 64^3 volume (the Shepp-Logan demo).

    python benchmarks/reference_speed.py [--size 128] [--volume 64] [--repeat 3] [--filter gaussian]

Prints a table: renderer, compositing, filter, shading, seconds (median of the repeats)
and volume samples (or field evaluations) per second.
"""

from __future__ import annotations

import argparse
import statistics
import time

from dvr_gl.bench import picks
from dvr_gl.renderers import create_renderer
from dvr_gl.scene.resolve import load_scene

# (judge, compositing, filter, shading): "discrete" is the same-discretization reference, "converged" the
# converged one (dvr_gl.bench.picks tells them apart by what they declare)
CASES = [
    ("discrete", "emission_absorption", "linear", False),
    ("discrete", "emission_absorption", "linear", True),
    ("discrete", "emission_absorption", "cubic_bspline", False),
    ("discrete", "emission_absorption", "gaussian", False),
    ("discrete", "isosurface", "linear", True),
    ("discrete", "average", "linear", False),
    ("discrete", "mip", "linear", False),
    ("converged", "emission_absorption", "linear", False),
    ("converged", "emission_absorption", "linear", True),
    ("converged", "emission_absorption", "gaussian", False),
    ("converged", "isosurface", "linear", True),
    ("converged", "mip", "linear", False),
]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--volume", type=int, default=64)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--filter", help="only the cases with this filter (e.g. gaussian)")
    args = p.parse_args()
    print(f"image {args.size}x{args.size}, Shepp-Logan {args.volume}^3, sample distance 0.5 voxel, "
          f"median of {args.repeat}")
    print(f"{'renderer':20s} {'compositing':20s} {'filter':14s} {'shading':7s} {'seconds':>8s} {'samples/s':>10s}")
    for judge, mode, filt, shading in CASES:
        if args.filter and filt != args.filter:
            continue
        name = getattr(picks, judge)()
        scene = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": args.volume,
                                  "image.width": args.size, "image.height": args.size,
                                  "renderer.compositing": mode, "renderer.filter": filt,
                                  "renderer.shading.enabled": shading, "renderer.iso_value": 0.3})
        renderer = create_renderer(name)
        times = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            renderer.render(scene)
            times.append(time.perf_counter() - start)
        t = statistics.median(times)
        samples = renderer.stats.get("samples") or renderer.stats.get("evaluations", 0)
        print(f"{name:20s} {mode:20s} {filt:14s} {str(shading):7s} {t:8.2f} {samples / t:10.3g}")


if __name__ == "__main__":
    main()
