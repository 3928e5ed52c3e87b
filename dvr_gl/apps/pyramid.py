"""Write a volume as a multi-resolution OME-Zarr image (NGFF 0.4): level 0 the full resolution, each
further level halved with a low-pass filter (the tent [1 2 1]/4 on the nodes; docs/multiresolution.md),
written level by level in bounded memory.  The pyramid is read back by dvr render/view/info with
--level L (0: full resolution).  OUT is never overwritten."""

from __future__ import annotations

import sys

from .info import file_options

HELP = "write a volume as an OME-Zarr multi-resolution pyramid (low-pass levels)"


def add_arguments(p):
    p.add_argument("input", metavar="IN", help="a volume file dvr reads (raw needs --dims and --dtype)")
    p.add_argument("output", metavar="OUT.zarr", help="the OME-Zarr folder to create (must not exist)")
    p.add_argument("--levels", type=int, metavar="N",
                   help="levels in all, full resolution included (default: halve until the largest side is at "
                        "most 32 samples)")
    p.add_argument("--chunks", type=int, default=64, metavar="N", help="chunk side in samples (default 64)")
    p.add_argument("--unit", metavar="UNIT", help="the axes' unit, an OME-Zarr space unit (e.g. millimeter)")
    v = p.add_argument_group("input options (as dvr render's)")
    file_options(v, "reader (default: by suffix)", ".vti, zarr: the array")
    v.add_argument("--level", type=int, metavar="L", help="OME-Zarr input: the resolution level to start from")


def run(args) -> int:
    import os

    from dvr_gl.errors import VolumeError
    from dvr_gl.multires.pyramid import _zarr, open_source, write_pyramid

    if os.path.lexists(args.output):  # refused before anything is read
        raise VolumeError(f"{args.output}: already exists; choose a new name for the pyramid (it is never "
                          f"overwritten)")
    if args.levels is not None and args.levels < 1:
        raise VolumeError(f"--levels must be at least 1 (1: full resolution only), got {args.levels}")
    from pathlib import Path

    from dvr_gl.image import check_writable

    check_writable(Path(args.output))  # its folder exists, is writable and inside the sandbox: before any work
    _zarr()  # the extra, checked before a large input is opened
    volume = _open(args, open_source)
    try:
        plan = write_pyramid(volume, args.output, levels=args.levels, chunks=args.chunks, unit=args.unit)
    except OSError as exc:  # a folder that refuses what access() allowed (/proc, a full or read-only disk)
        raise VolumeError(f"{args.output}: cannot write the pyramid ({exc.strerror or exc}); choose another "
                          f"folder") from None
    if tuple(map(tuple, volume.direction)) != ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        print("dvr pyramid: note: OME-Zarr 0.4 has no rotation: the volume's direction matrix is kept in the "
              "metadata only, and the pyramid is read back unrotated", file=sys.stderr)
    if not getattr(args, "quiet", False):
        for index, (dims, spacing, origin, _) in enumerate(plan):
            print(f"level {index}: {'x'.join(map(str, dims))}, spacing {', '.join(f'{s:g}' for s in spacing)}")
        print(f"wrote {args.output}")
    return 0


def _open(args, open_source):
    """The input, read out of core where it is larger than the memory budget and its format allows."""
    options = {"format": args.format, "dims": args.dims, "dtype": args.dtype, "endian": args.endian,
               "header_bytes": args.header_bytes, "array": args.array, "level": args.level}
    return open_source(args.input, **options)
