"""The ray caster's benches: ``dvr bench raycast`` (frame time and samples per ray of the core loop,
:mod:`.frames`) ``dvr bench accel`` (what early termination and empty-space skipping save and cost,
:mod:`.acceleration`) and ``dvr bench channels`` (several fields against one, :mod:`.channels`).
Declared by the plugin (``bench=``); the measurement is imported when run.
"""

from __future__ import annotations

from ....transfer_function import PRESETS
from ...bench_command import BenchCommand, count, on_shared_data, shared_data_arguments


def _frame_arguments(p):
    p.add_argument("--volume", metavar="FILE", help="a volume file (default: the Shepp-Logan phantom)")
    p.add_argument("--volume-size", type=int, default=256, help="phantom samples per axis (default 256)")
    p.add_argument("--size", type=int, default=512, help="square image size (default 512)")
    p.add_argument("--repeat", type=count, default=5, help="timed frames per case, after a warm-up (default 5)")
    p.add_argument("--transfer-function", choices=list(PRESETS), help="preset (default: the volume's)")
    p.add_argument("--rescale-intercept", type=float, default=0.0)
    p.add_argument("--up", type=float, nargs=3, metavar=("X", "Y", "Z"), help="camera up (default +z)")


def _frames(args) -> int:
    from . import frames

    base = {"image.width": args.size, "image.height": args.size, "renderer.name": "raycast",
            "renderer.acceleration": False}  # the core loop; dvr bench accel measures acceleration
    if args.volume:
        base["volume.path"] = args.volume
    else:
        base.update({"volume.demo": "shepp-logan", "volume.size": args.volume_size})
    if args.transfer_function:
        base["transfer_function.preset"] = args.transfer_function
        base["transfer_function.rescale_intercept"] = args.rescale_intercept
    if args.up:
        base["camera.up"] = list(args.up)
    args.report.text(f"dvr bench raycast: {args.repeat} timed frames per case after a warm-up, sample distance "
                     f"0.5 voxel, acceleration structures off")
    args.report.table(frames.run(base, repeat=args.repeat), frames.COLUMNS)
    return 0


def _accel_arguments(p):
    shared_data_arguments(p)
    p.add_argument("--views", type=count, default=6, help="azimuths of the alternating comparison (default 6)")
    p.add_argument("--volume-size", type=int, default=256,
                   help="phantom samples per axis of the dense scenes (default 256)")
    p.add_argument("--part", choices=("datasets", "overhead", "both"), default="both",
                   help="the shared datasets' table, the alternating comparison, or both (default)")


def _accel(args) -> int:
    from . import acceleration

    if args.part in ("datasets", "both"):
        on_shared_data(args, acceleration, f"dvr bench accel: {args.size}x{args.size} images, sample distance "
                       f"0.5 voxel, 8^3 blocks, {args.repeat} timed frames per case after a warm-up")
    if args.part in ("overhead", "both"):
        from pathlib import Path

        data_dir = Path(args.data_dir)  # the datasets join the phantoms where the folder is there
        scenes = [(name, {"volume.path": str(data_dir / path), **overrides})
                  for name, path, overrides in acceleration.DATASETS
                  if (data_dir / path).exists() and (not args.only or args.only.lower() in name.lower())]
        scenes = [s for s in acceleration.dense_scenes(args.volume_size)
                  if not args.only or args.only.lower() in s[0].lower()] + scenes
        args.report.text()
        args.report.text(f"What skipping costs and saves, one process: {args.size}x{args.size} images, "
                         f"elevation 20, {args.views} azimuths from 30 degrees; per azimuth off, on and auto "
                         f"alternate, 2 rounds, the fastest frame of each (draw to glFinish); ratios to off per "
                         f"azimuth, median and worst. Phantoms at 1 voxel per sample, the demo at 0.25, the datasets "
                         f"at 0.5; early termination at the default 1 - 1/255")
        args.report.table(acceleration.overhead(scenes, args.size, args.views), acceleration.OVERHEAD_COLUMNS)
    return 0


def _channels_arguments(p):
    p.add_argument("--volume", metavar="FILE", help="a multichannel file (default: phantom channels)")
    p.add_argument("--volume-size", type=int, default=128, help="phantom samples per axis (default 128)")
    p.add_argument("--size", type=int, default=512, help="square image size (default 512)")
    p.add_argument("--repeat", type=count, default=5, help="timed rounds after a warm-up (default 5)")


def _channels(args) -> int:
    from . import channels

    data = args.volume or f"{args.volume_size}^3 phantom channels"
    args.report.text(f"dvr bench channels: several fields against one field's frame, {data}, {args.size}x"
                     f"{args.size}, acceleration off, {args.repeat} interleaved rounds after a warm-up, median "
                     f"draw-to-glFinish time")
    args.report.table(channels.run(args.volume_size, args.size, args.repeat, args.volume), channels.COLUMNS)
    return 0


COMMANDS = (
    BenchCommand("raycast", "GPU ray caster: frame time, samples per ray, samples per second", _frame_arguments,
                 _frames),
    BenchCommand("accel", "acceleration on the datasets in ../shared/data: samples, frame time, error; and what "
                 "skipping costs on dense data (on and auto against off, alternating views)", _accel_arguments,
                 _accel),
    BenchCommand("channels", "several fields: 1-4 channels on one grid and 2 on separate grids against one "
                 "field's frame", _channels_arguments, _channels),
)
