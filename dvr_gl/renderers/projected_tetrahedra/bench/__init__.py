"""Projected tetrahedra's bench: ``dvr bench cells``, the shared meshes' order and draw time, cells per
second and error against the mesh reference, beside VTK's projected tetrahedra (:mod:`.measure`).
Declared by the plugin (``bench=``); the measurement is imported when run.
"""

from __future__ import annotations

from ...bench_command import SHARED_DATA, BenchCommand, count

MESH_NAMES = ("bluntfin", "comb", "post", "jaw", "notch", "tetraMesh")  # dvr_gl.bench.datasets.MESHES (a test checks)


def _arguments(p):
    p.add_argument("--data-dir", default=SHARED_DATA, help=f"the shared datasets folder (default {SHARED_DATA})")
    p.add_argument("--meshes", metavar="A,B", help=f"only these ({', '.join(MESH_NAMES)}; default all)")
    p.add_argument("--size", type=int, default=512, help="square image size of the timed frames (default 512)")
    p.add_argument("--error-size", type=int, default=256,
                   help="square image size of the error against reference-converged (default 256)")
    p.add_argument("--frames", type=count, default=3, help="timed frames per case, after one untimed (default 3)")
    p.add_argument("--peers-python", metavar="PYTHON",
                   help="the peers environment's interpreter, for VTK (default .venv-peers/bin/python if it exists)")
    p.add_argument("--only-pt", action="store_true",
                   help="only projected tetrahedra (exact order: exact and shirley-tuchman integration; "
                        "shirley-tuchman in VTK's centroid order) and VTK")
    p.add_argument("--pictures", metavar="DIR", help="write cells-MESH.png into DIR: the first view's reference, "
                                                     "dvr-gl, resampled ray casting and VTK, above 5x their errors")


def _run(args) -> int:
    from pathlib import Path

    from ....bench import peers
    from ....errors import DvrError
    from . import measure

    names = args.meshes.split(",") if args.meshes else list(measure.MESHES)
    unknown = [x for x in names if x not in measure.MESHES]
    if unknown:
        raise DvrError(f"--meshes: unknown {', '.join(unknown)}; choose from {', '.join(measure.MESHES)}")
    for flag, value in (("--size", args.size), ("--error-size", args.error_size)):
        if not 8 <= value <= 4096:
            raise DvrError(f"{flag} must be 8 to 4096 pixels, got {value}")
    if not Path(args.data_dir).is_dir():
        raise DvrError(f"--data-dir {args.data_dir}: no such folder (the shared datasets)")
    if args.peers_python and not Path(args.peers_python).exists():
        raise DvrError(f"--peers-python {args.peers_python}: no such interpreter")
    python = args.peers_python or peers.default_peers_python()
    if args.pictures and not Path(args.pictures).is_dir():
        raise DvrError(f"{args.pictures}: no such folder for the pictures; create it first")
    args.report.text(f"dvr bench cells: the shared meshes, {args.size}x{args.size}, perspective 30 degrees, framed, "
                     f"views azimuth/elevation {', '.join(f'{a:g}/{e:g}' for a, e in measure.VIEWS)}; median of "
                     f"{args.frames} frames after one untimed (dvr-gl: order and draw of the median frame, every "
                     f"frame sorted again; its cases' frames interleaved, one VTK frame in each round; VTK ms / ms "
                     f"above 1: dvr-gl faster)"
                     f"; RMS against reference-converged at {args.error_size}x{args.error_size}")
    rows, notes = measure.run(names, Path(args.data_dir), args.size, args.error_size, args.frames, python,
                              pictures=Path(args.pictures) if args.pictures else None, only_pt=args.only_pt,
                              progress=lambda r: print(f"{r['mesh']} {r['view']} {r['renderer']}: {r['ms']:.0f} ms, "
                                                       f"RMS {r['rms']:.2e}", flush=True))
    args.report.text()
    args.report.table(rows, measure.COLUMNS, notes + measure.against_vtk(rows))
    return 0


COMMANDS = (BenchCommand("cells", "projected tetrahedra on the shared meshes: order and draw time, cells per "
                         "second, error against the mesh reference; VTK's projected tetrahedra beside it when the "
                         "peers' environment has VTK (docs/meshes.md)", _arguments, _run),)
