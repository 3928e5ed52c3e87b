"""Empty-space skipping in bricked ray casting: frame time with acceleration off, on and auto, in
one pass and in 8 bricks (2 x 2 x 2, resident: no uploads per frame), on CThead with the bone
preset (sparse) and the Marschner-Lobb demo with the viridis preset (dense: no block skippable).

    python dvr_gl/renderers/raycast/benchmarks/bricked_skipping.py [--size 512] [--views 4] [--repeat 3] [--markdown]

Per view (azimuths 30 + 360 i / views, elevation 20) the settings alternate ``repeat`` rounds and the
fastest draw of each counts (draw calls to glFinish, no read-back); ratios are taken per view, the
table gives their median (and worst over the views). Samples per ray are counted by the shader in a
warm-up frame, over all passes.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
from pathlib import Path

from dvr_gl.renderers.grid.bricking import Brick, ghost_width
from dvr_gl.renderers.grid.views import GridView
from dvr_gl.renderers.raycast.renderer import RayCastRenderer
from dvr_gl.scene.resolve import load_scene

DATA = Path(__file__).resolve().parents[5] / "shared" / "data"
HU = {"transfer_function.rescale_intercept": -1024.0}
SCENES = [
    ("CThead, bone", {"volume.path": str(DATA / "regular/cthead.nhdr"), "transfer_function.preset": "ct-bone-ivory",
                      **HU, "camera.up": [0, 0, -1], "renderer.ert_threshold": 1.0}),
    ("CThead, bone, ERT 0.99", {"volume.path": str(DATA / "regular/cthead.nhdr"),
                                "transfer_function.preset": "ct-bone-ivory", **HU, "camera.up": [0, 0, -1],
                                "renderer.ert_threshold": 0.99}),
    ("Marschner-Lobb 128^3, viridis", {"volume.demo": "marschner-lobb", "volume.size": 128,
                                       "transfer_function.preset": "viridis", "renderer.ert_threshold": 1.0}),
]


class EightBricks(RayCastRenderer):
    """The ray caster with every volume in 2 x 2 x 2 bricks (cores split at the middle voxel)."""

    def grid_views(self, scene, defines):
        r, dims = scene.renderer, scene.volume.dims
        central = ("SHADING" in defines or "GRADIENT_OPACITY" in defines) and "GRADIENT_TEXTURE" not in defines
        ghost = ghost_width(r.filter, central, self.brick_reach(scene))
        views = []
        for index in itertools.product(range(2), repeat=3):
            mid = [(n - 1) // 2 for n in dims]
            lo = tuple(0 if i == 0 else m for i, m in zip(index, mid))
            hi = tuple(m if i == 0 else n - 1 for i, m, n in zip(index, mid, dims))
            tex_lo = tuple(max(a - ghost, 0) for a in lo)
            tex_hi = tuple(min(b + ghost, n - 1) for b, n in zip(hi, dims))
            brick = Brick(index, lo, hi, tex_lo, tuple(b - a + 1 for a, b in zip(tex_lo, tex_hi)),
                          tuple(i == 1 for i in index))
            views.append(GridView(brick.tex_lo, brick.tex_dims, brick))
        return views


def measure(size: int, views: int, repeat: int) -> list[dict]:
    renderers = {1: RayCastRenderer(), 8: EightBricks(ctx=None)}
    rows = []
    try:
        for name, overrides in SCENES:
            base = {"image.width": size, "image.height": size, "camera.elevation": 20.0, **overrides}
            volume = load_scene(None, base).volume
            configs = [(bricks, mode) for bricks in (1, 8) for mode in ("off", "on", "auto")]
            ms = {c: [] for c in configs}
            samples = {c: [] for c in configs}
            accelerated = {c: [] for c in configs}
            for view in range(views):
                azimuth = 30.0 + 360.0 * view / views
                scenes = {c: load_scene(None, {**base, "camera.azimuth": azimuth, "renderer.acceleration": c[1]})
                          .replace(volume=volume) for c in configs}
                for c in configs:  # warm-up: programs, textures, block classes; counted samples
                    r = renderers[c[0]]
                    r.count_samples = True
                    r.render(scenes[c])
                    assert r.stats["bricks"] == c[0]
                    samples[c].append(r.stats["samples_per_ray"])
                    accelerated[c].append(r.stats["accelerated"])
                    r.count_samples = False
                    r.render(scenes[c])
                best = {c: float("inf") for c in configs}
                for _ in range(repeat):
                    for c in configs:
                        renderers[c[0]].render(scenes[c])
                        best[c] = min(best[c], renderers[c[0]].stats["gpu_seconds"])
                for c in configs:
                    ms[c].append(best[c] * 1e3)
            for bricks in (1, 8):
                off = ms[(bricks, "off")]
                row = {"scene": name, "bricks": bricks}
                for mode in ("off", "on", "auto"):
                    c = (bricks, mode)
                    row[f"{mode}_ms"] = statistics.median(ms[c])
                    row[f"{mode}_samples"] = statistics.median(samples[c])
                    if mode != "off":
                        ratios = [a / b for a, b in zip(ms[c], off)]
                        row[f"{mode}_ratio"], row[f"{mode}_worst"] = statistics.median(ratios), max(ratios)
                row["auto_on"] = sum(accelerated[(bricks, "auto")])
                one = ms[(1, "off")]
                row["vs_one_pass_off"] = statistics.median([a / b for a, b in zip(off, one)])
                rows.append(row)
    finally:
        for r in renderers.values():
            r.close()
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--views", type=int, default=4)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = p.parse_args()
    rows = measure(args.size, args.views, args.repeat)
    print(f"{args.size}x{args.size}, sample distance 0.5 voxel, 8^3 blocks, {args.views} views, "
          f"fastest of {args.repeat} per view")
    head = ["scene", "bricks", "off ms", "on ms", "on/off (worst)", "auto ms", "auto/off (worst)",
            "auto skipped views", "samples/ray off", "samples/ray on", "off / one pass off"]
    if args.markdown:
        print("| " + " | ".join(head) + " |")
        print("|---|" + "---:|" * (len(head) - 1))
    for r in rows:
        cells = [r["scene"], str(r["bricks"]), f"{r['off_ms']:.1f}", f"{r['on_ms']:.1f}",
                 f"{r['on_ratio']:.2f} ({r['on_worst']:.2f})", f"{r['auto_ms']:.1f}",
                 f"{r['auto_ratio']:.2f} ({r['auto_worst']:.2f})", f"{r['auto_on']}/{args.views}",
                 f"{r['off_samples']:.1f}", f"{r['on_samples']:.1f}", f"{r['vs_one_pass_off']:.2f}"]
        print(("| " + " | ".join(cells) + " |") if args.markdown else "  ".join(cells))


if __name__ == "__main__":
    main()
