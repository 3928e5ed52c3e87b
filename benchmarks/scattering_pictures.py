"""Pictures of single scattering for the docs (docs/images/scattering-shadow.png).

    python benchmarks/scattering_pictures.py [--size 320] [--out docs/images]

The shadow demo (a ball above a floor, lit from above beside the eye), left to right: the ray
caster with the light volume at the demo's 128 nodes, with a light volume of 32 nodes (the nodes
show on the shadow's edge), and with shadow rays (0.25 voxel, as the demo's view rays). The
timings printed are one frame each on this machine, the light volume's making included.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from dvr_gl.image import side_by_side, write_image
from dvr_gl.phantoms import demo_scene
from dvr_gl.renderers import create_renderer
from dvr_gl.scene import load_scene

REPO = Path(__file__).resolve().parent.parent
SETTINGS = ({}, {"renderer.scattering.light_volume_size": 32}, {"renderer.scattering.method": "shadow_rays"})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=320)
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    pictures = []
    with create_renderer("raycast") as raycast:
        for extra in SETTINGS:
            scene = load_scene(None, {"image.width": args.size, "image.height": args.size, **extra},
                               demo_scene("shadow"))
            start = time.perf_counter()
            pictures.append(raycast.render(scene))
            print(f"{extra or 'the demo'}: {time.perf_counter() - start:.2f} s")
    out = Path(args.out) / "scattering-shadow.png"
    write_image(out, side_by_side(pictures), overwrite=True)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
