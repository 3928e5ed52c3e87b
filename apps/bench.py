"""Benchmarks that print a table (speed and memory targets live here, not in unit tests).

  dvr bench raycast    frame time and samples per ray of the GPU ray caster
"""

from __future__ import annotations

from dvr_gl.bench import format_table
from dvr_gl.transfer_function import PRESETS

HELP = "run a benchmark and print its table"


def add_arguments(p):
    sub = p.add_subparsers(dest="benchmark", metavar="BENCHMARK", required=True)
    rc = sub.add_parser("raycast", help="GPU ray caster: frame time, samples per ray, samples per second")
    rc.add_argument("--volume", metavar="FILE", help="a volume file (default: the Shepp-Logan phantom)")
    rc.add_argument("--volume-size", type=int, default=256, help="phantom samples per axis (default 256)")
    rc.add_argument("--size", type=int, default=512, help="square image size (default 512)")
    rc.add_argument("--repeat", type=int, default=5, help="timed frames per case, after a warm-up (default 5)")
    rc.add_argument("--transfer-function", choices=list(PRESETS), help="preset (default: the volume's)")
    rc.add_argument("--rescale-intercept", type=float, default=0.0)
    rc.add_argument("--up", type=float, nargs=3, metavar=("X", "Y", "Z"), help="camera up (default +z)")


def run(args) -> int:
    from dvr_gl.bench import raycast

    base = {"image.width": args.size, "image.height": args.size, "renderer.name": "raycast"}
    if args.volume:
        base["volume.path"] = args.volume
    else:
        base.update({"volume.demo": "shepp-logan", "volume.size": args.volume_size})
    if args.transfer_function:
        base["transfer_function.preset"] = args.transfer_function
        base["transfer_function.rescale_intercept"] = args.rescale_intercept
    if args.up:
        base["camera.up"] = list(args.up)
    print(f"dvr bench raycast: {args.repeat} timed frames per case after a warm-up, sample distance 0.5 voxel")
    print(format_table(raycast.run(base, repeat=args.repeat), raycast.COLUMNS))
    return 0
