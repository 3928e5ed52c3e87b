"""What a renderer's ``dvr bench`` subcommand declares (:class:`BenchCommand`), and the flags and checks
that the bench subcommands share.

A plugin names its commands in ``RendererPlugin.bench``; ``dvr`` reads them from the registry to build
``dvr bench NAME``.  ``dvr`` builds every subcommand's flags before it runs any command (``dvr render``
too), so this module and a renderer's command module stay light: they import the bench harness
(:mod:`dvr_gl.bench`, the optional extra) and the measurement only inside ``run``.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..errors import DvrError

SHARED_DATA = "../shared/data"  # the shared datasets folder, relative to the working folder


@dataclass(frozen=True)
class BenchCommand:
    """One ``dvr bench NAME`` subcommand.

    name: the subcommand (``dvr bench NAME``); help: its line in ``dvr bench --help``;
    add_arguments: ``add_arguments(parser)`` adds its flags; run: ``run(args) -> int`` measures and
    prints to ``args.report`` (a :class:`dvr_gl.bench.Report`, which ``--markdown FILE`` writes), inside
    the harness's frame counter; the exit status.
    """

    name: str
    help: str
    add_arguments: Callable
    run: Callable


def count(text: str) -> int:
    """A flag's whole number of at least 1 (frames, repeats)."""
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"give a whole number of at least 1, got {text!r}")
    return n


def fraction(text: str) -> float:
    """A flag's fraction of the value range, in (0, 1]."""
    try:
        x = float(text)
    except ValueError:
        x = math.nan
    if not 0 < x <= 1:
        raise argparse.ArgumentTypeError(f"give a fraction of the value range in (0, 1], got {text!r}")
    return x


def timing_arguments(p, size: int, error_size: int):
    """``--size`` (timings), ``--error-size`` (errors against reference-converged) and ``--repeat``."""
    p.add_argument("--size", type=int, default=size, help=f"square image size of the timings (default {size})")
    p.add_argument("--error-size", type=int, default=error_size, help="square image size of the errors against "
                                                                      f"reference-converged (default {error_size})")
    p.add_argument("--repeat", type=count, default=3, help="timed frames per case, after a warm-up (default 3)")


def shared_data_arguments(p, size: int = 512):
    """``--data-dir``, ``--size``, ``--repeat`` and ``--only`` of a bench over the shared datasets."""
    p.add_argument("--data-dir", default=SHARED_DATA, help=f"the shared datasets folder (default {SHARED_DATA})")
    p.add_argument("--size", type=int, default=size, help=f"square image size (default {size})")
    p.add_argument("--repeat", type=count, default=5, help="timed frames per case, after a warm-up (default 5)")
    p.add_argument("--only", metavar="TEXT", help="only datasets whose name contains TEXT")


def wrote(args, what):
    """The files a bench wrote, on stdout with its tables (not with -q)."""
    if not getattr(args, "quiet", False):
        print(f"wrote {what}")


def chosen_datasets(args, datasets):
    """The shared datasets folder (checked) and the entries of ``datasets`` that ``--only`` keeps
    (any case)."""
    data_dir = Path(args.data_dir)
    if not data_dir.is_dir():
        raise DvrError(f"{data_dir}: the shared datasets folder was not found; pass --data-dir")
    return data_dir, [d for d in datasets if not args.only or args.only.lower() in d[0].lower()]


def on_shared_data(args, module, title: str) -> int:
    """Run a benchmark over the shared datasets (``module.DATASETS``, filtered by ``--only``):
    ``module.run(data_dir, size, repeat, datasets)`` gives the rows of ``module.COLUMNS`` and notes."""
    data_dir, datasets = chosen_datasets(args, module.DATASETS)
    args.report.text(title)
    rows, notes = module.run(data_dir, args.size, args.repeat, datasets)
    args.report.table(rows, module.COLUMNS, notes)
    return 0


def shared_regular_scenes(args):
    """The regular shared datasets in ``--data-dir`` (``--only``, case kept) with notes on those left out;
    one line if the folder or the choice is empty."""
    from ..bench.datasets import shared_scenes

    if not Path(args.data_dir).is_dir():
        raise DvrError(f"--data-dir {args.data_dir}: no such folder (the shared datasets)")
    scenes, notes = shared_scenes(Path(args.data_dir), args.only)
    if not scenes:
        raise DvrError(f"--only {args.only}: no shared dataset matches")
    return scenes, notes


def check_ranges(checks):
    """Each ``(flag, value, low, high)``: the value in [low, high], or one line naming the flag."""
    for flag, value, low, high in checks:
        if not low <= value <= high:
            raise DvrError(f"{flag} must be {low} to {high}, got {value}")


def commands(declared) -> tuple[BenchCommand, ...]:
    """A plugin's ``bench`` as a tuple of commands (it may name one or several)."""
    from ..scene.plugin import load

    found = load(declared)
    return tuple(found) if isinstance(found, (tuple, list)) else (found,)
