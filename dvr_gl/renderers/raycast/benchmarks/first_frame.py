"""First frame against later frames of the ray caster (issue 15, item 6), each scene in a fresh process.

    python dvr_gl/renderers/raycast/benchmarks/first_frame.py [--data-dir ../shared/data] [--size 512] [--runs 3]

A child process loads the scene (not timed), then times ``render()`` (wall clock, read-back
included) of the first frame and of 5 later ones; it also reports what the first frame built
(the renderer's cache entries and how long each took, from a profile-free clock around the
texture, pyramid and class builders) so that the ratio can be explained.  Mesa's on-disk shader
cache is left as it is (a user's second session finds the program compiled); ``--cold`` points
MESA_SHADER_CACHE_DIR at a fresh folder for every run.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = r'''
import json, sys, time
from dvr_gl.scene.resolve import load_scene
from dvr_gl.renderers.raycast.renderer import RayCastRenderer
overrides = json.loads(sys.argv[1])
scene = load_scene(None, overrides)
r = RayCastRenderer()
t = time.perf_counter(); r.render(scene); first = time.perf_counter() - t
later = []
for _ in range(5):
    t = time.perf_counter(); r.render(scene); later.append(time.perf_counter() - t)
print(json.dumps({"first": first, "later": sorted(later)[2], "accelerated": r.stats["accelerated"],
                  "bounds": r.stats["ray_bounds"]}))
'''


def scenes(data_dir: Path, size: int, work: Path):
    from dvr_gl.bench import peers

    out = []
    for key in ("ml-composite", "ml-mip", "blobs-composite"):  # the issue's scenes: 256^3 uint8, 1 voxel
        demo = peers.SCENES[key][0]
        keys = peers.scene_keys(key, peers.volume_file(demo, 256, work), size)
        out.append((f"{key} (bench peers) 256^3 uint8", keys))
    common = {"image.width": size, "image.height": size, "camera.azimuth": 30.0, "camera.elevation": 20.0}
    out += [(f"{d} 256^3 float, viridis", {"volume.demo": d, "volume.size": 256, "transfer_function.preset": "viridis",
                                           **common}) for d in ("marschner-lobb", "blobs")]
    out.append(("marschner-lobb 256^3 float, MIP", {"volume.demo": "marschner-lobb", "volume.size": 256,
                                                    "renderer.compositing": "mip", **common}))
    hu = {"transfer_function.rescale_intercept": -1024.0}
    for name, path, extra in [("CThead, bone", "regular/cthead.nhdr", {"camera.up": [0, 0, -1]}),
                              ("CT bunny, bone", "large/bunny_ct.nhdr", {})]:
        if (data_dir / path).exists():
            out.append((name, {"volume.path": str(data_dir / path), "transfer_function.preset": "ct-bone-ivory", **hu,
                               **common, **extra}))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data-dir", default=str(Path(__file__).resolve().parents[5] / "shared" / "data"))
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--cold", action="store_true", help="an empty Mesa shader cache for every run")
    args = p.parse_args(argv)
    print("scene | first frame ms | later frame ms | first / later | ray bounds | block skipping")
    work = tempfile.TemporaryDirectory(prefix="dvr-first-frame-")
    for name, overrides in scenes(Path(args.data_dir), args.size, Path(work.name)):
        results = []
        for _ in range(args.runs):
            env = dict(os.environ)
            with tempfile.TemporaryDirectory() as cache:
                if args.cold:
                    env["MESA_SHADER_CACHE_DIR"] = cache
                out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(overrides)], env=env,
                                     capture_output=True, text=True, check=True).stdout
            results.append(json.loads(out.splitlines()[-1]))
        first = statistics.median(r["first"] for r in results)
        later = statistics.median(r["later"] for r in results)
        print(f"{name} | {1e3 * first:.0f} | {1e3 * later:.0f} | {first / later:.2f} | "
              f"{'on' if results[0]['bounds'] else 'off'} | {'on' if results[0]['accelerated'] else 'off'}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
