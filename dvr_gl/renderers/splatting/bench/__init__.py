"""Splatting's bench: ``dvr bench splatting``, its sheet buffers and classifications: frame time, splats,
error against the same kernel's converged reference, the ray caster at equal error; the 45-degree study
(:mod:`.measure`).  Declared by the plugin (``bench=``); the measurement is imported when run.
"""

from __future__ import annotations

from ...bench_command import SHARED_DATA, BenchCommand, check_ranges, count, shared_regular_scenes


def _arguments(p):
    p.add_argument("--volume-size", type=int, default=64, help="phantom samples per axis (default 64; 0: no phantom)")
    p.add_argument("--particles", type=int, default=4096, help="also an SPH set: a Plummer sphere of about this "
                   "many particles (default 4096; 0: none)")
    p.add_argument("--size", type=int, default=128, help="square image size (default 128)")
    p.add_argument("--repeat", type=count, default=3, help="timed frames per case, after a warm-up (default 3)")
    p.add_argument("--shared", action="store_true", help="the regular datasets in --data-dir instead of the "
                                                         "phantom (long: a converged reference each)")
    p.add_argument("--data-dir", default=SHARED_DATA, help=f"the shared datasets folder (default {SHARED_DATA})")
    p.add_argument("--only", metavar="TEXT", help="with --shared: only datasets whose name contains TEXT")
    p.add_argument("--no-shaded", action="store_true", help="leave out the shaded row (its converged reference "
                   "computes gradients at every sample: over an hour on CThead)")
    p.add_argument("--peers", action="store_true", help="instead: the column density of SPH particles against "
                   "sarracen (numba), one interleaved run (docs/particles.md)")
    p.add_argument("--peer-particles", default="10000,100000,1000000", help="with --peers: the Plummer spheres' "
                   "particle counts, comma-separated (default 10000,100000,1000000)")
    p.add_argument("--peer-size", type=int, default=512, help="with --peers: square image size (default 512)")
    p.add_argument("--peers-python", help="with --peers: the peers' interpreter, where sarracen is installed "
                   "(default .venv-peers/bin/python if it exists; without one dvr-gl alone)")
    p.add_argument("--kernel-radius", type=float, default=None, metavar="SIGMAS", help="where the grids' Gaussian "
                   "is cut, in standard deviations (renderer.kernel_radius, 3 to 6; default the model's 5): 4 "
                   "drops 1.1e-3 of its mass for fewer splats and pairs")
    p.add_argument("--study-size", type=int, default=48, help="square image size of the 45-degree study "
                                                             "(default 48; 0 leaves it out)")


def _scenes(args) -> tuple[list, list]:
    """The scenes measured (``(name, overrides)``) and notes on the shared datasets left out."""
    from ....errors import DvrError
    from . import measure

    check_ranges((("--size", args.size, 8, 4096), ("--volume-size", args.volume_size, 0, 4096),
                  ("--study-size", args.study_size, 0, 4096), ("--particles", args.particles, 0, 10 ** 7)))
    notes = []
    if args.shared:
        scenes, notes = shared_regular_scenes(args)
    elif args.volume_size:
        scenes = [(f"Shepp-Logan {args.volume_size}^3", _phantom(args))]
    else:
        scenes = []
    if args.volume_size == 1:
        raise DvrError("--volume-size must be 0 (no phantom) or 2 to 4096, got 1")
    if args.particles:
        scenes.append(measure.plummer_scene(args.particles))
    if not scenes:
        raise DvrError("nothing to measure: --volume-size 0 and --particles 0")
    return scenes, notes


def _phantom(args) -> dict:
    return {"volume.demo": "shepp-logan", "volume.size": args.volume_size}


def _kernel(args) -> dict:
    """The grids' kernel keys: ``--kernel-radius`` where given."""
    return {} if args.kernel_radius is None else {"renderer.kernel_radius": args.kernel_radius}


def _run(args) -> int:
    from . import measure

    if args.peers:
        return _run_peers(args)
    scenes, notes = _scenes(args)
    scenes = [(name, {**keys, **_kernel(args)}) for name, keys in scenes]  # (particles take their own kernel)
    cut = f"cut at {args.kernel_radius:g}" if args.kernel_radius is not None else "cut at the model's 5"
    args.report.text(f"dvr bench splatting: {args.size}x{args.size}, the Gaussian of width 0.7 ({cut} standard "
                     f"deviations; particles: their cubic spline), default camera and "
                     f"transfer function, "
                     f"{'no shading (the shaded row left out)' if args.no_shaded else 'no shading but the shaded row'}"
                     f"; median of {args.repeat} frames after a warm-up; "
                     f"RMS against reference-converged of the same kernel and classification (tolerance 1e-4)")
    rows = measure.run(scenes, args.size, args.repeat, shaded=not args.no_shaded, progress=lambda r: print(
        f"{r['dataset']} {r['scheme']} {r['classification']}: {r['ms']:.0f} ms, RMS {r['rms']:.2e}", flush=True))
    args.report.text()
    args.report.table(rows, measure.COLUMNS, notes)
    if args.study_size and args.volume_size:
        args.report.text(f"\nthe 45-degree study: Shepp-Logan {args.volume_size}^3 at {args.study_size}x"
                         f"{args.study_size}, elevation 0, post-classified; the largest change of each image between "
                         f"azimuth - {measure.STUDY_STEP:g} and + {measure.STUDY_STEP:g} degrees")
        args.report.table(measure.study(_phantom(args), args.study_size), measure.STUDY_COLUMNS)
    return 0


def _run_peers(args) -> int:
    from ....errors import DvrError
    from . import peers

    try:
        counts = [int(n) for n in args.peer_particles.split(",")]
    except ValueError:
        raise DvrError(f"--peer-particles must be whole numbers separated by commas, got {args.peer_particles!r}")
    check_ranges((("--peer-size", args.peer_size, 8, 4096),) + tuple(("--peer-particles", n, 1, 10 ** 7)
                                                                      for n in counts))
    python = args.peers_python or peers.default_python()
    args.report.text(f"dvr bench splatting --peers: the column density of a Plummer sphere (M4, support 2h) at "
                     f"{args.peer_size}x{args.peer_size}, viewed along -z over the particles' extent, sampled at "
                     f"pixel centres; median of {args.repeat} frames each, dvr-gl and sarracen in turn, after a "
                     f"warm-up (sarracen's numba compile excluded); error: RMS against the exact column (float64) "
                     f"over its peak" + ("" if python else "; no peers' interpreter: dvr-gl alone"))
    rows = peers.run(counts, args.peer_size, args.repeat, python)
    args.report.text()
    args.report.table(rows, peers.COLUMNS)
    return 0


COMMANDS = (BenchCommand("splatting", "splatting's schemes: frame time, splats drawn and culled, error against its "
                         "oracle and the same kernel's converged reference, the ray caster at equal error; the "
                         "45-degree study (docs/renderers/splatting.md)", _arguments, _run),)
