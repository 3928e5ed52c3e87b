"""Fourier volume rendering's bench: ``dvr bench fourier``, the pre-processing and time per view against N,
the error against reference-converged and the ray caster at equal error; with ``--shared``, the accuracy
study on the regular shared datasets (:mod:`.measure`).  Declared by the plugin (``bench=``); the
measurement is imported when run.
"""

from __future__ import annotations

from ...bench_command import SHARED_DATA, BenchCommand, shared_regular_scenes, timing_arguments


def _arguments(p):
    p.add_argument("--sizes", default="64,128,256", metavar="N,N", help="volume sizes, the blobs demo N^3 "
                                                                         "(default 64,128,256)")
    timing_arguments(p, size=512, error_size=128)
    p.add_argument("--no-front", action="store_true", help="skip the error-vs-time fronts (the per-size table only)")
    p.add_argument("--shared", action="store_true", help="the accuracy study instead: every regular dataset in "
                                                         "--data-dir at --error-size, against reference-converged")
    p.add_argument("--data-dir", default=SHARED_DATA, help=f"the shared datasets folder (default {SHARED_DATA})")
    p.add_argument("--only", metavar="TEXT", help="with --shared: only datasets whose name contains TEXT")


def _run(args) -> int:
    from ....errors import DvrError
    from . import measure

    try:
        sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        raise DvrError(f"--sizes: a comma-separated list of volume sizes, got {args.sizes!r}") from None
    for flag, values, low, high in (("--sizes", sizes, 4, 1024), ("--size", [args.size], 8, 4096),
                                    ("--error-size", [args.error_size], 8, 4096)):
        if not all(low <= v <= high for v in values):
            raise DvrError(f"{flag} must be {low} to {high}, got {', '.join(map(str, values))}")
    if args.shared:
        return _shared(args, measure)
    args.report.text(f"dvr bench fourier: the blobs demo N^3, orthographic, the average and the pre-classified X-ray; "
                     f"times at {args.size}x{args.size} (wall time a view, medians of {args.repeat} after a warm-up, "
                     f"fourier and {measure.BASELINE} interleaved), RMS against reference-converged at "
                     f"{args.error_size}x{args.error_size} of the same framing (tolerance 1e-4)")
    rows, points, verdicts = measure.run(sizes, args.size, args.error_size, args.repeat, progress=lambda r: print(
        f"{r['n']}^3 {r['mode']}: spectrum {r['spectrum_s']:.2f} s, {r['view_ms']:.1f} ms a view, the ray caster "
        f"{r['raycast_ms']:.1f} ms ({r['speedup']:.2f}x)", flush=True), front=not args.no_front)
    args.report.text()
    args.report.table(rows, measure.COLUMNS)
    if args.no_front:
        return 0
    args.report.text()
    args.report.text(f"Error against time at {max(sizes)}^3 (ms at {args.size}x{args.size}, RMS at "
                     f"{args.error_size}x{args.error_size}); every point timed in one interleaved run (each in "
                     f"turn, medians of {args.repeat} rounds):")
    args.report.table(points, measure.FRONT_COLUMNS)
    for line in verdicts:
        args.report.text(line)
    return 0


def _shared(args, measure) -> int:
    """The accuracy study on the regular shared datasets, at the plugin's default settings."""
    from .. import PADDING, SLICE_BANDWIDTH, SLICE_INTERPOLATION, SLICE_TAPS

    scenes, notes = shared_regular_scenes(args)
    defaults = ", ".join(f"{setting.name} {setting.default:g}" if isinstance(setting.default, float)
                         else f"{setting.name} {setting.default}" for setting in
                         (SLICE_INTERPOLATION, SLICE_TAPS, PADDING, SLICE_BANDWIDTH))
    args.report.text(f"dvr bench fourier --shared: each regular dataset at {args.error_size}x{args.error_size}, "
                     f"orthographic, default camera and transfer function, the defaults (trilinear field, "
                     f"{defaults}), against reference-converged (tolerance 1e-4); the last column with "
                     f"slice_taps 6 and slice_bandwidth 2")
    rows = measure.shared(scenes, args.error_size, progress=lambda r: print(
        f"{r['dataset']} {r['mode']}: RMS / max {r['rms_rel']:.2e}", flush=True))
    args.report.text()
    args.report.table(rows, measure.SHARED_COLUMNS, notes)
    return 0


COMMANDS = (BenchCommand("fourier", "Fourier volume rendering against the ray caster: the spectrum's time, time per "
                         "view against N (interleaved with the ray caster), both error-vs-time fronts "
                         "(docs/renderers/fourier.md)", _arguments, _run),)
