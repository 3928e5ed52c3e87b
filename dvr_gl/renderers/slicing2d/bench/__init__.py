"""The 2D texture stacks' bench: ``dvr bench slicing``, the stacks against view-aligned slices across view
angles: the error, the jump when the stack switches, and pictures (:mod:`.measure`).  Declared by the
plugin (``bench=``); the measurement is imported when run.
"""

from __future__ import annotations

from ...bench_command import BenchCommand, wrote


def _arguments(p):
    p.add_argument("--volume", metavar="FILE", help="a volume file (default: the Shepp-Logan phantom)")
    p.add_argument("--volume-size", type=int, default=64, help="phantom samples per axis (default 64; 0: no phantom)")
    p.add_argument("--size", type=int, default=128, help="square image size (default 128)")
    p.add_argument("--pictures", metavar="DIR", help="write slicing_sweep.png and slicing_jump.png into DIR")
    p.add_argument("--overwrite", action="store_true", help="replace pictures that exist")


def _run(args) -> int:
    from pathlib import Path

    from ....errors import DvrError
    from . import measure

    pictures = Path(args.pictures) if args.pictures else None
    if pictures is not None:
        if not pictures.is_dir():
            raise DvrError(f"{pictures}: no such folder for the pictures; create it first")
        measure.check_pictures(pictures, args.overwrite)
    base = measure.base_scene(args.volume_size, args.size, args.volume)
    what = args.volume or f"Shepp-Logan {args.volume_size}^3"
    args.report.text(f"dvr bench slicing: {what}, {args.size}x{args.size}, elevation 0, one slice per voxel, RMS "
                     f"error against the converged reference")
    rows, jumps, written = measure.run(base, pictures=pictures, overwrite=args.overwrite)
    args.report.table(rows, measure.COLUMNS)
    args.report.text(f"\nimage change (RMS) between azimuth - {measure.JUMP_STEP:g} and + {measure.JUMP_STEP:g} "
                     f"degrees; the stacks switch at 45")
    args.report.table(jumps, measure.JUMP_COLUMNS)
    for path in written:
        wrote(args, path)
    return 0


COMMANDS = (BenchCommand("slicing", "slicing2d against slicing3d across azimuths: error, stack-switch jump, "
                         "pictures", _arguments, _run),)
