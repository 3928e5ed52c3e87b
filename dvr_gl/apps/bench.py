"""Benchmarks that print a table (speed and memory targets live here, not in unit tests).

A renderer's own benches are declared by its plugin (``RendererPlugin.bench``) and listed from the
registry; these measure across renderers, which they pick by what the plugins declare:

  dvr bench quality    error against the converged reference versus samples: post-classified and
                       pre-integrated, for a narrow transfer-function spike
  dvr bench renderers  frame time of the GPU grid renderers, post-classified and pre-integrated,
                       from one texture and from bricks
  dvr bench tradeoff   every renderer x accuracy setting: frame time against error (RMS, max, PSNR,
                       FLIP) versus the converged reference, the Pareto front; CSV, JSON and a plot
  dvr bench scattering single scattering: shadow rays, the light volume and half-angle slicing, frame
                       time and error against reference-converged, the speed-up at equal error
  dvr bench scale      frame time against Dask workers (and a model to N), time and memory against the
                       volume's size, the multi-resolution error
  dvr bench peers      dvr-gl against VTK, vispy and pygfx (from a separate benchmark environment) on
                       the same scenes: frame time, error against the converged reference, ratios
  dvr bench widget     the notebook widget under simulated pointer events: frames per second while
                       dragging, the time from release to the full image
  dvr bench gpu        every renderer's frame time at GPU sizes (512^3 to 1024x1024) within a time budget,
                       the device named; a Markdown table and a JSON file in --out (docs/gpu.md)

The measurements are the optional extra ``bench`` (plots and FLIP);
they are imported only when a bench runs.
"""

from __future__ import annotations

import logging

from dvr_gl.errors import install_hint
from dvr_gl.phantoms import DEMOS
from dvr_gl.renderers import registry
from dvr_gl.renderers.bench_command import (
    SHARED_DATA,
    chosen_datasets,
    commands,
    count,
    fraction,
    shared_data_arguments,
    timing_arguments,
    wrote,
)

HELP = "run a benchmark and print its table"

log = logging.getLogger(__name__)

SCATTERING_SHARED = ("bucky", "nucleon", "neghip", "ironProt")
SCATTERING_DATASETS = ("bucky", "nucleon", "neghip", "ironProt", "headsq", "hydrogen", "brainsmall", "lobster",
                       "CThead", "MNI152")  # dvr_gl.bench.datasets.REGULAR's names (a test checks)


def add_arguments(p):
    sub = p.add_subparsers(dest="benchmark", metavar="BENCHMARK", required=True)
    for command in renderer_benches():
        parser = sub.add_parser(command.name, help=command.help)
        command.add_arguments(parser)
        parser.set_defaults(bench=command.run)
    for name, (help_, arguments, run_) in HARNESS.items():
        parser = sub.add_parser(name, help=help_)
        arguments(parser)
        parser.set_defaults(bench=run_)
    for parser in sub.choices.values():
        parser.add_argument("--markdown", metavar="FILE", help="also write the tables as Markdown to FILE (the "
                                                               "measured tables in docs/ are written this way)")
        if "--overwrite" not in parser._option_string_actions:
            parser.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    _feedback_arguments(sub)


def renderer_benches() -> list:
    """The ``dvr bench`` subcommands the registered renderers declare (``RendererPlugin.bench``), in the
    registry's order; a plugin whose bench does not load is left out with a warning (as a broken plugin)."""
    found, names = [], set(HARNESS)
    for plugin in registry.plugins().values():
        if plugin.bench is None:
            continue
        try:
            declared = commands(plugin.bench)
        except Exception as exc:  # a broken third-party bench must not take dvr down
            log.warning("%s: its bench %s failed to load (%s: %s)", plugin.name, plugin.bench, type(exc).__name__, exc)
            continue
        for command in declared:
            if command.name in names:
                log.warning("%s: a bench named %r exists already; its own is left out", plugin.name, command.name)
                continue
            names.add(command.name)
            found.append(command)
    return found


def _quality_arguments(qu):
    qu.add_argument("--size", type=int, default=128, help="square image size (default 128)")
    qu.add_argument("--volume-size", type=int, default=41, help="Marschner-Lobb samples per axis (default 41)")
    qu.add_argument("--spike-width", type=fraction, metavar="W",
                    help="only this spike width, a fraction of the value range (default: 0.02 and 0.005)")


def _renderers_arguments(rn):
    rn.add_argument("--volume", metavar="FILE", help="a volume file (default: the Shepp-Logan phantom)")
    rn.add_argument("--volume-size", type=int, default=256, help="phantom samples per axis (default 256)")
    rn.add_argument("--size", type=int, default=512, help="square image size (default 512)")
    rn.add_argument("--repeat", type=count, default=5, help="timed frames per case, after a warm-up (default 5)")
    rn.add_argument("--budget", type=float, default=48.0, metavar="MB",
                    help="texture budget of the bricked runs, MB (default 48)")


def _tradeoff_arguments(to):
    to.add_argument("scene", nargs="?", metavar="SCENE.toml", help="the scene (or --demo, or --shared)")
    to.add_argument("--demo", choices=list(DEMOS), help="a built-in demo scene")
    to.add_argument("--volume-size", type=int, default=64, help="demo samples per axis (default 64)")
    to.add_argument("--shared", action="store_true", help="the datasets in ../shared/data (see --data-dir, --only)")
    shared_data_arguments(to, size=128)
    to.add_argument("--renderers", metavar="A,B", help="only these renderers (default: every one with a sweep)")
    to.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="set any scene key")
    to.add_argument("--output", default="tradeoff", metavar="PREFIX",
                    help="write PREFIX.csv, PREFIX.json and PREFIX.png (default: tradeoff)")
    to.add_argument("--overwrite", action="store_true", help="replace output files that exist")
    to.add_argument("--no-plot", action="store_true", help="skip the PNG plot")


def _peers_arguments(pe):
    pe.add_argument("--size", type=int, default=512, help="square image size of the timed frames (default 512)")
    pe.add_argument("--error-size", type=int, default=128,
                    help="square image size of the error measurement against the converged reference (default 128)")
    pe.add_argument("--volume-size", type=int, default=256, help="phantom samples per axis (default 256)")
    pe.add_argument("--rounds", type=count, default=3, help="rounds of fresh processes, interleaved (default 3)")
    pe.add_argument("--frames", type=count, default=20, help="timed frames per run, after one untimed (default 20)")
    scenes = pe.add_argument("--scenes", metavar="A,B", help="only these scenes (default all)")
    renderers = pe.add_argument("--renderers", metavar="A,B", help="only these (default all)")
    plain = pe.format_help

    def format_help():
        """The help with the scenes and renderers the harness knows, listed from its code: imported only when
        the help is asked for (``dvr render`` builds this parser too, and must not import the harness)."""
        from dvr_gl.bench import peers

        first, second, third = (len(peers.HELD_OUT_SETS[k]) for k in ("held-out", "held-out-2", "held-out-3"))
        scenes.help = (f"only these scenes ({', '.join(peers.SCENES)}; \"held-out\" for the {first} before "
                       f"the last {second + third}, never tuned on; \"held-out-2\" for the {second} before the "
                       f"last {third} and \"held-out-3\" for the last {third}, each declared on 2026-11-29 "
                       f"before any run; default all)")
        renderers.help = f"only these ({', '.join(peers.RENDERERS)}; default all)"
        return plain()

    pe.format_help = format_help
    pe.add_argument("--sweep", metavar="D,D", help="dvr-gl's sample distances in voxels besides its defaults "
                                                  "(default 1,2,4,8; MIP scenes also with the extremum refined, "
                                                  "default 0.75,1,2)")
    pe.add_argument("--data-dir", default="../shared/data", help="the shared datasets folder, for the CThead "
                                                                  "scene (default ../shared/data; left out if absent)")
    pe.add_argument("--peers-python", metavar="PYTHON",
                    help="the peers environment's interpreter (default .venv-peers/bin/python if it exists)")
    pe.add_argument("--cache", metavar="DIR", help="where converged references are kept (default "
                                                   "~/.cache/dvr-gl/peers)")
    pe.add_argument("--pictures", metavar="DIR", help="write each scene's images side by side into DIR (PNG)")
    pe.add_argument("--plot", metavar="FILE", help="draw each peer against dvr-gl's error-time curve (PNG; "
                                                   "needs matplotlib)")


def _scattering_arguments(sc):
    timing_arguments(sc, size=256, error_size=64)
    sc.add_argument("--tolerance", type=float, default=1e-4, help="reference-converged's budget (default 1e-4)")
    sc.add_argument("--demo-size", type=int, default=64, help="the shadow demo's samples per axis (default 64)")
    sc.add_argument("--light-volume-sizes", default="32,64,128,256", metavar="N,N",
                    help="the light volume's sizes swept (default 32,64,128,256)")
    sc.add_argument("--shared", action="store_true", help="also the small shared datasets (bucky, nucleon, neghip, "
                                                          "ironProt) in --data-dir, lit by a default light (long: a "
                                                          "converged reference each)")
    sc.add_argument("--datasets", metavar="A,B", help="also these shared datasets, by name (any of "
                    + ", ".join(SCATTERING_DATASETS) + "), lit by the same light")
    sc.add_argument("--shadow-ray-distances", default="2,1,0.75,0.5,0.375,0.25", metavar="D,D",
                    help="the shadow rays' sample distances swept, voxels (default 2,1,0.75,0.5,0.375,0.25)")
    sc.add_argument("--data-dir", default=SHARED_DATA, help=f"the shared datasets folder (default {SHARED_DATA})")
    sc.add_argument("--only", metavar="TEXT", help="only scenes whose name contains TEXT")
    sc.add_argument("--paths", type=int, default=64, help="Monte Carlo paths per pixel of the multiple-scattering "
                                                          "table (default 64; 0 leaves it out)")
    sc.add_argument("--paths-size", type=int, default=32, help="square image size of that table (default 32)")


def _scale_arguments(sa):
    sa.add_argument("--part", choices=("workers", "sizes", "levels", "all"), default="all",
                    help="which measurement (default all)")
    sa.add_argument("--out", dest="markdown", metavar="FILE", help="also write the tables as Markdown to FILE")
    sa.add_argument("--sizes", type=lambda text: [float(v) for v in text.split(",")], metavar="GIB,...",
                    help="sizes: the volumes' sizes in GiB (default 1,2,4,8,16)")
    sa.add_argument("--data-dir", metavar="DIR", help="sizes: where the synthetic volumes are written once and "
                                                     "kept (default: the temporary folder)")
    sa.add_argument("--size", type=int, default=512, help="square image size, pixels (default 512)")


def _widget_arguments(p):
    # declared here, not in dvr_gl.bench.widget: building the parser must not import the bench harness
    p.add_argument("--size", type=int, default=512, help="square widget size, pixels (default 512)")
    p.add_argument("--volume", metavar="FILE", help="a volume file (default: the Shepp-Logan demo, --volume-size)")
    p.add_argument("--volume-size", type=int, default=128, help="the demo's size, voxels a side (default 128)")
    p.add_argument("--renderer", action="append", metavar="NAME", help="a renderer to measure (repeat; default: "
                                                                       "the GL renderers that take the data)")
    p.add_argument("--moves", type=int, default=30, help="timed drag moves (default 30)")
    p.add_argument("--warm-up", type=int, default=10, help="untimed drag moves first (default 10)")
    p.add_argument("--budget", type=float, default=0.1, help="the widget's frame budget while dragging, seconds "
                                                             "(default 0.1: 10 frames a second)")


def _gpu_arguments(p):
    # declared here, not in dvr_gl.bench.gpu: building the parser must not import the bench harness
    p.add_argument("--out", metavar="DIR", help="the folder for gpu-bench.md and gpu-bench.json (default: $OUT)")
    p.add_argument("--volume", metavar="FILE", help="the grid: a volume file (default: the Shepp-Logan demo, "
                                                    "--volume-size)")
    p.add_argument("--volume-size", type=int, default=512, help="the demo's nodes a side (default 512)")
    p.add_argument("--size", type=int, default=1024, help="square image size, pixels (default 1024)")
    p.add_argument("--mesh-size", type=int, metavar="M", help="the mesh's points a side, 12 (M-1)^3 tetrahedra "
                                                              "(default: volume size / 16 + 1)")
    p.add_argument("--particles", type=int, metavar="N", help="SPH particles of the Plummer demo (default: "
                                                              "(volume size / 2)^3, at most 10^6)")
    p.add_argument("--frames", type=count, default=5, help="timed frames per case, after the first (default 5)")
    p.add_argument("--time-budget", type=float, default=300.0, metavar="SECONDS",
                   help="the whole bench's time; larger sizes that would overrun it are left out, saying so "
                        "(default 300)")
    p.add_argument("--peers-python", metavar="PYTHON",
                   help="the peers environment's interpreter (default .venv-peers/bin/python if it exists)")
    p.add_argument("--no-peers", action="store_true", help="leave the peers out")
    p.add_argument("--overwrite", action="store_true", help="replace the files in --out if they exist")


def run_gpu(args) -> int:
    from dvr_gl.bench import gpu

    return gpu.run(args)


def _feedback_arguments(sub):
    """``-q``/``-v`` after the benchmark's name too (``dvr bench tradeoff -q``)."""
    from .progress import add_arguments

    for parser in sub.choices.values():
        add_arguments(parser)


def run(args) -> int:
    from pathlib import Path

    from dvr_gl.bench import Report, counting
    from dvr_gl.image import check_writable, write_text

    if args.markdown:  # before measuring: fail fast, overwrite nothing unasked
        check_writable(Path(args.markdown), args.overwrite)
    args.report = Report()
    with counting(f"dvr bench {args.benchmark}"):  # a bar of the frames measured, after a second
        code = args.bench(args)
    if args.markdown:
        write_text(Path(args.markdown), args.report.markdown(args.command_line), args.overwrite)
        wrote(args, args.markdown)
    return code


def run_scale(args) -> int:
    from dvr_gl.bench import scale
    from dvr_gl.errors import DvrError

    if not 8 <= args.size <= 4096:
        raise DvrError(f"--size must be 8 to 4096, got {args.size}")
    return scale.run(args)


def run_widget(args) -> int:
    from dvr_gl.bench import widget

    return widget.run(args)


def run_quality(args) -> int:
    from dvr_gl.bench import quality

    widths = [args.spike_width] if args.spike_width is not None else quality.WIDTHS
    for width in widths:
        n = quality.table_size(width)
        args.report.text(f"dvr bench quality: Marschner-Lobb {args.volume_size}^3, extinction spike "
                         f"{100 * width:g} % of the range wide, {args.size}x{args.size}, against the converged "
                         f"reference (tolerance 1e-5), pre-integration table {n}x{n}")
        rows, lines, builds = quality.run(args.size, args.volume_size, width)
        args.report.table(rows, quality.COLUMNS)
        for line in lines:
            args.report.text(line)
        args.report.text(f"table build at {n}x{n}: exact {builds['exact']:.2f} s, fast {builds['fast']:.2f} s\n")
    return 0


def run_renderers(args) -> int:
    from dvr_gl.bench import renderers, volume_keys

    volume, what = volume_keys(args.volume, args.volume_size)
    base = {"image.width": args.size, "image.height": args.size, **volume}
    args.report.text(f"dvr bench renderers: {what}, {args.size}x{args.size}, sample distance 0.5 voxel "
                     f"(2D stacks: the voxel planes), early termination and acceleration off, {args.repeat} timed "
                     f"frames per case after a warm-up; bricked under {args.budget:g} MB")
    args.report.table(renderers.run(base, args.repeat, args.budget), renderers.COLUMNS)
    return 0


def _tradeoff_scenes(args):
    """(name, scene) pairs to sweep: the SCENE file, the demo, or the shared datasets."""
    from pathlib import Path

    from dvr_gl.errors import DvrError
    from dvr_gl.phantoms import demo_scene
    from dvr_gl.scene.resolve import load_scene

    from .render import set_overrides

    given = [bool(args.scene), bool(args.demo), args.shared]
    if sum(given) != 1:
        raise DvrError("give one of SCENE.toml, --demo NAME or --shared")
    overrides = {"image.width": args.size, "image.height": args.size, **set_overrides(args.set)}
    if args.scene:
        return [(Path(args.scene).stem, load_scene(args.scene, overrides))]
    if args.demo:
        overrides["volume.size"] = args.volume_size
        return [(args.demo, load_scene(None, overrides, demo_scene(args.demo)))]
    from dvr_gl.bench.tradeoff import DATASETS

    data_dir, chosen = chosen_datasets(args, DATASETS)
    scenes = []
    for name, path, extra in chosen:
        if not (data_dir / path).exists():
            log.warning("%s: %s not found, skipped", name, data_dir / path)
            continue
        scenes.append((name, load_scene(None, {"volume.path": str(data_dir / path), **extra, **overrides})))
    if not scenes:
        raise DvrError(f"no dataset of the tradeoff list was found in {data_dir}")
    return scenes


def run_tradeoff(args) -> int:
    import time
    from pathlib import Path

    from dvr_gl.bench import plot, tradeoff
    from dvr_gl.errors import DvrError
    from dvr_gl.image import check_writable, write_text

    renderers = args.renderers.split(",") if args.renderers else None
    swept = tradeoff.sweeps()
    unknown = [r for r in renderers or () if r not in swept]
    if unknown:
        raise DvrError(f"--renderers: no sweep for {', '.join(unknown)}; choose from {', '.join(swept)}")
    outputs = {ext: Path(f"{args.output}.{ext}") for ext in ("csv", "json", "png")}
    drawing = not args.no_plot and plot.have_matplotlib()
    for ext, path in outputs.items():  # before measuring: fail fast, overwrite nothing unasked
        if ext != "png" or drawing:
            check_writable(path, args.overwrite)
    scenes = _tradeoff_scenes(args)
    all_rows, meta = [], {"repeat": args.repeat, "size": args.size, "scenes": {}}
    for name, scene in scenes:
        start = time.perf_counter()
        truth = tradeoff.converged_truth(scene)
        args.report.text(f"dvr bench tradeoff: {name} ({scene.field.describe()}), {args.size}x{args.size}, median of "
              f"{args.repeat} frames after a warm-up; error against the converged reference "
              f"({time.perf_counter() - start:.1f} s to compute)")
        rows, notes = tradeoff.run(scene, args.repeat, renderers, truth, scene_name=name)
        args.report.table(rows, tradeoff.COLUMNS, notes)
        checks, note = tradeoff.tolerance_check(scene, rows, truth, args.repeat)
        if checks:
            args.report.text("\n--tolerance E: the error model's choice, measured, against the measured front")
            args.report.table(checks, tradeoff.TOLERANCE_COLUMNS)
        else:
            args.report.text(note)
        if rows and rows[0]["flip"] is None:
            args.report.text(f"FLIP: not measured (install the optional extra: {install_hint('bench')})")
        args.report.text()
        meta["scenes"][name] = {"notes": notes, "tolerance": checks, "scene": scene.to_dict()}
        all_rows += rows
    if not all_rows:
        raise DvrError("no renderer measured these scenes (the notes above say why); nothing written")
    write_text(outputs["csv"], tradeoff.csv_text(all_rows), args.overwrite)
    write_text(outputs["json"], tradeoff.json_text(all_rows, meta), args.overwrite)
    written = [outputs["csv"], outputs["json"]]
    if drawing:
        from dvr_gl.image import atomic_write

        atomic_write(outputs["png"], lambda tmp: plot.tradeoff_plot(all_rows, tmp), args.overwrite)
        written.append(outputs["png"])
    elif not args.no_plot:
        log.warning(f"no plot: install the optional extra for plots: {install_hint('bench')}")
    wrote(args, ", ".join(map(str, written)))
    return 0


def run_scattering(args) -> int:
    from pathlib import Path

    from dvr_gl.bench import scattering
    from dvr_gl.bench.datasets import shared_scenes
    from dvr_gl.errors import DvrError

    for flag, value, low, high in (("--size", args.size, 8, 4096), ("--error-size", args.error_size, 8, 4096),
                                   ("--paths", args.paths, 0, 100_000), ("--paths-size", args.paths_size, 4, 1024),
                                   ("--demo-size", args.demo_size, 4, 1024)):
        if not low <= value <= high:
            raise DvrError(f"{flag} must be {low} to {high}, got {value}")
    if not 1e-8 <= args.tolerance <= 0.1:
        raise DvrError(f"--tolerance must be 1e-8 to 0.1, got {args.tolerance}")
    try:
        sizes = tuple(int(n) for n in args.light_volume_sizes.split(","))
    except ValueError:
        raise DvrError(f"--light-volume-sizes: a comma-separated list of node counts, got "
                       f"{args.light_volume_sizes!r}") from None
    if not all(2 <= n <= 256 for n in sizes):
        raise DvrError(f"--light-volume-sizes must be 2 to 256 nodes each, got {args.light_volume_sizes}")
    try:
        distances = tuple(float(d) for d in args.shadow_ray_distances.split(","))
    except ValueError:
        raise DvrError(f"--shadow-ray-distances: a comma-separated list of voxels, got "
                       f"{args.shadow_ray_distances!r}") from None
    if not all(1.0 / 64.0 <= d <= 64.0 for d in distances):
        raise DvrError(f"--shadow-ray-distances must be 1/64 to 64 voxels each, got {args.shadow_ray_distances}")
    wanted = set(SCATTERING_SHARED) if args.shared else set()
    if args.datasets:
        names = [n.strip() for n in args.datasets.split(",") if n.strip()]
        unknown = [n for n in names if n not in SCATTERING_DATASETS]
        if unknown:
            raise DvrError(f"--datasets: no shared dataset named {', '.join(unknown)} (the names: "
                           f"{', '.join(SCATTERING_DATASETS)})")
        wanted |= set(names)
    scenes, notes = [scattering.shadow_demo(args.demo_size)], []
    if wanted:
        if not Path(args.data_dir).is_dir():
            raise DvrError(f"--data-dir {args.data_dir}: no such folder (the shared datasets)")
        found, notes = shared_scenes(Path(args.data_dir))
        scenes += [(n, o) for n, o in found if n in wanted]
    if args.only:
        scenes = [(n, o) for n, o in scenes if args.only in n]
        if not scenes:
            raise DvrError(f"--only {args.only}: no scene matches")
    args.report.text(f"dvr bench scattering: single scattering (emission-absorption, no gradient shading) by the "
                     f"ray caster's shadow rays and light volume and slicing3d's half-angle slicing, frame times at "
                     f"{args.size}x{args.size} (median of {args.repeat} after a "
                     f"warm-up; the light volume made once, timed apart), RMS against reference-converged "
                     f"(tolerance {args.tolerance:g}) at {args.error_size}x{args.error_size}; the shared datasets "
                     f"lit by one directional light (0.4, 0.6, -1), albedo 0.9")
    rows = scattering.run(scenes, args.size, args.error_size, args.repeat, args.tolerance, light_volume_sizes=sizes,
                          shadow_ray_distances=distances,
                          progress=lambda r: print(
        f"{r['scene']} {r['renderer']} {r['method']} {r['setting']}: {r['ms']:.0f} ms, RMS {r['rms']:.2e}",
        flush=True))
    args.report.text()
    args.report.table(rows, scattering.COLUMNS, notes)
    args.report.text("\nat equal error: each shadow-ray setting against the fastest light volume or half-angle "
                     "setting as accurate")
    args.report.table(scattering.equal_error(rows), scattering.EQUAL_COLUMNS)
    if args.paths:
        args.report.text(f"\nwhat single scattering leaves out: reference-converged (single scattering) against the "
                         f"Monte Carlo reference (every order; delta tracking, seed 0) at {args.paths_size}x"
                         f"{args.paths_size}, {args.paths} paths per pixel")
        rows = scattering.multiple(scenes, args.paths_size, args.paths, args.tolerance, progress=lambda r: print(
            f"{r['scene']}: single {r['single']:.4f}, all orders {r['full']:.4f}", flush=True))
        args.report.table(rows, scattering.MULTIPLE_COLUMNS)
    return 0


def run_peers(args) -> int:
    from pathlib import Path

    from dvr_gl.bench import peers, plot
    from dvr_gl.errors import DvrError
    from dvr_gl.image import atomic_write, check_writable

    scenes = args.scenes.split(",") if args.scenes else list(peers.SCENES)
    scenes = [x for name in scenes for x in peers.HELD_OUT_SETS.get(name, (name,))]
    renderers = args.renderers.split(",") if args.renderers else list(peers.RENDERERS)
    for what, given, known, named in (("--scenes", scenes, peers.SCENES, tuple(peers.HELD_OUT_SETS)),
                                      ("--renderers", renderers, peers.RENDERERS + ("numpy",), ())):
        unknown = [x for x in given if x not in known]
        if unknown:
            raise DvrError(f"{what}: unknown {', '.join(unknown)}; choose from {', '.join([*known, *named])}")
    for flag, value, low in (("--size", args.size, 8), ("--error-size", args.error_size, 8),
                             ("--volume-size", args.volume_size, 4)):
        if value < low:
            raise DvrError(f"{flag} must be at least {low}, got {value}")
    try:
        sweep = tuple(float(x) for x in args.sweep.split(",")) if args.sweep else None
    except ValueError:
        raise DvrError(f"--sweep {args.sweep}: give sample distances in voxels, e.g. 1,2,4,8") from None
    if sweep is not None and not all(0 < d < 1e4 for d in sweep):
        raise DvrError(f"--sweep {args.sweep}: every sample distance must be above 0 voxels and below 10000")
    python = args.peers_python or peers.default_peers_python()
    if args.peers_python and not Path(args.peers_python).exists():
        raise DvrError(f"--peers-python {args.peers_python}: no such interpreter")
    drawing = bool(args.plot) and plot.have_matplotlib()
    if drawing:
        check_writable(Path(args.plot), args.overwrite)
    pictures = Path(args.pictures) if args.pictures else None
    if pictures is not None and not pictures.is_dir():
        raise DvrError(f"{pictures}: no such folder for the pictures; create it first")
    cache = Path(args.cache) if args.cache else peers.default_cache()
    datasets = ", ".join(dict.fromkeys(peers.SCENES[s][0] for s in scenes if peers.SCENES[s][0] in peers.DATASETS))
    args.report.text(f"dvr bench peers: {args.volume_size}^3 uint8 phantoms and the shared datasets ({datasets} from "
                     f"--data-dir), {args.size}x{args.size} frames, perspective "
                     f"30 degrees, azimuth 30, elevation 20, distance {peers.DISTANCE_DIAGONALS:g} box diagonals, "
                     f"trilinear, unshaded; {args.rounds} rounds of fresh processes interleaved across renderers, "
                     f"median of {args.frames} frames each after one untimed; error (RMS, PSNR: premultiplied RGBA, "
                     f"peak 1) against dvr-gl's converged reference at {args.error_size}x{args.error_size}; peers at "
                     f"{peers.PEER_SAMPLE_VOXELS:g} sample per voxel")
    rows, ratios, notes, images = peers.run(renderers, scenes, args.size, args.volume_size, args.rounds, args.frames,
                                            args.error_size, python, cache,
                                            progress=lambda line: print(line, flush=True),
                                            data_dir=Path(args.data_dir), sweep=sweep)
    args.report.text()
    args.report.table(rows, peers.COLUMNS)
    if ratios:
        args.report.text()
        args.report.text(f"dvr-gl at each peer's error: the fastest dvr-gl setting above whose PSNR is at least the "
                         f"peer's minus {peers.PSNR_SLACK:g} dB; ratio > 1: dvr-gl is faster")
        args.report.table(ratios, peers.RATIO_COLUMNS)
    versions = sorted({f"{r['renderer']} {r['version']}" for r in rows if r["renderer"] != "dvr-gl" and r["version"]})
    if versions:
        args.report.text()
        args.report.text("Versions: " + ", ".join(versions))
    for note in notes:
        args.report.text(note)
    if not rows:
        raise DvrError("no scene was measured (the notes above say why); give --data-dir the shared datasets' folder")
    if pictures is not None:
        references = images.pop("references")
        for path in peers.write_pictures(images, references, pictures):
            wrote(args, path)
    if drawing:
        atomic_write(Path(args.plot), lambda tmp: plot.peers_plot(rows, tmp), args.overwrite)
        wrote(args, args.plot)
    elif args.plot:
        log.warning(f"no plot: install the optional extra for plots: {install_hint('bench')}")
    return 0


# The benches across renderers: name: (help, add_arguments, run).
HARNESS = {
    "quality": ("error versus sample spacing, post-classified and pre-integrated", _quality_arguments, run_quality),
    "renderers": ("frame time of raycast, slicing3d and slicing2d, whole and bricked", _renderers_arguments,
                  run_renderers),
    "tradeoff": ("error against frame time for every renderer and accuracy setting; CSV, JSON and a log-log plot "
                 "with the Pareto front", _tradeoff_arguments, run_tradeoff),
    "peers": ("dvr-gl against VTK, vispy and pygfx on the same scenes (the peers from a separate environment, "
              "docs/peers.md): frame time, error, speed ratios", _peers_arguments, run_peers),
    "scattering": ("single scattering: the ray caster's shadow rays and light volume and slicing3d's half-angle "
                   "slicing at several settings, frame time and RMS against reference-converged, the speed-up at "
                   "equal error (docs/scattering.md)", _scattering_arguments, run_scattering),
    "scale": ("scaling: frame time against the number of Dask workers (and a model to N workers), time and peak "
              "memory against the volume's size, multi-resolution error (docs/distributed.md, "
              "docs/out-of-core.md)", _scale_arguments, run_scale),
    "widget": ("the notebook widget driven by simulated pointer events: frames per second while dragging, the time "
               "from release to the full image (docs/widget.md)", _widget_arguments, run_widget),
    "gpu": ("every renderer's frame time at GPU sizes within a time budget, the device named; Markdown and JSON "
            "in --out (docs/gpu.md)", _gpu_arguments, run_gpu),
}
