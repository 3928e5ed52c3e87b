"""``dvr bench scale --part sizes``: time and peak resident memory against the volume's size.

Synthetic volumes (:mod:`dvr_gl.out_of_core.synthetic`: empty space, a thin shell, blobs) of 1 to
16 GiB are written once to a folder and rendered out of core by ``dvr render`` in a child process
under ``/usr/bin/time -v``, whose "Maximum resident set size" counts every page the process touched:
its heap, the pages of files it mapped, and on llvmpipe the textures too.  Each size renders twice:
``first`` (the block ranges' sidecar computed: one pass over the file) and ``again`` (the sidecar
read).  The claim checked per row: peak RSS <= the baseline (the same command on a 64^3 volume in
memory: Python, numpy, the GL driver, the programs) + ``renderer.memory_budget_mb`` (the host cache
of bricks) + ``renderer.texture_budget_mb`` (the resident textures).
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIZES_GIB = (1, 2, 4, 8, 16)
DTYPE = "uint16"
MEMORY_BUDGET_MB = 2048
TEXTURE_BUDGET_MB = 512
IMAGE = 512


def dims_for(gib: float, dtype: str = DTYPE) -> tuple[int, int, int]:
    """A near-cubic grid of ``gib`` GiB of ``dtype`` (x a little longer, so that axes are told apart)."""
    voxels = gib * 2 ** 30 / np.dtype(dtype).itemsize
    n = int(round((voxels / 1.25) ** (1 / 3)))
    return int(round(1.25 * n)), n, n


def volume_file(folder: Path, gib: float, dtype: str = DTYPE) -> Path:
    """The synthetic volume of ``gib`` GiB in ``folder`` (written if missing), as its .nhdr header."""
    from ..out_of_core.synthetic import write_synthetic_raw

    raw = folder / f"synthetic-{gib:g}GiB-{dtype}.raw"
    nhdr = raw.with_suffix(".nhdr")
    dims = dims_for(gib, dtype)
    if not (nhdr.exists() and raw.exists() and raw.stat().st_size == int(np.prod(dims)) * np.dtype(dtype).itemsize):
        write_synthetic_raw(raw, dims, dtype)
    return nhdr


def measured(command: list[str]) -> dict:
    """Run ``command`` under ``/usr/bin/time -v``: wall seconds, peak RSS (MiB), and what ``dvr render``
    printed of its own times."""
    start = time.perf_counter()
    done = subprocess.run(["/usr/bin/time", "-v", *command], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["?"])
        raise RuntimeError(f"{' '.join(command)} failed: {next((ln for ln in tail if 'Command' not in ln), tail[0])}")
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
    times = re.search(r"render ([\d.]+) s, total ([\d.]+) s", done.stdout + done.stderr)
    return {"wall": wall, "peak_mib": int(rss.group(1)) / 1024 if rss else float("nan"),
            "render": float(times.group(1)) if times else float("nan"),
            "total": float(times.group(2)) if times else float("nan")}


def render_command(volume: Path, out: Path, memory_mb: float, texture_mb: float, image: int,
                   out_of_core: bool = True) -> list[str]:
    """``dvr render`` of ``volume`` read out of core (forced: "auto" would load those under the budget)."""
    return [sys.executable, "-m", "dvr_gl", "render", str(volume), "-o", str(out), "--overwrite",
            "--size", str(image), "--set", f"renderer.memory_budget_mb={memory_mb:g}",
            "--set", f"renderer.texture_budget_mb={texture_mb:g}"] + (
            ["--set", "volume.out_of_core=true"] if out_of_core else [])


def run(args) -> str:
    """Print (and return) the table, to ``args.report`` where given (``dvr bench scale``); ``args``:
    ``sizes`` (GiB), ``data_dir``, ``memory_budget_mb``, ``texture_budget_mb``, ``size`` (image pixels),
    where given."""
    report = getattr(args, "report", None)
    say = report.text if report is not None else (lambda line: print(line, flush=True))
    sizes = getattr(args, "sizes", None) or SIZES_GIB
    memory_mb = getattr(args, "memory_budget_mb", None) or MEMORY_BUDGET_MB
    texture_mb = getattr(args, "texture_budget_mb", None) or TEXTURE_BUDGET_MB
    image = getattr(args, "size", None) or IMAGE
    folder = Path(getattr(args, "data_dir", None) or Path(tempfile.gettempdir()) / "dvr-bench-scale")
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / "frame.png"
    small = folder / "baseline.npy"
    if not small.exists():
        np.save(small, np.zeros((64, 64, 64), np.uint16))
    baseline = measured(render_command(small, out, memory_mb, texture_mb, image, out_of_core=False))
    bound = baseline["peak_mib"] + memory_mb + texture_mb
    lines = [f"Out of core: {DTYPE} synthetic volumes, {image}x{image}, renderer.memory_budget_mb = {memory_mb:g}, "
             f"renderer.texture_budget_mb = {texture_mb:g}; baseline (64^3 in memory) peak "
             f"{baseline['peak_mib']:.0f} MiB, so the bound is {bound:.0f} MiB.", "",
             "| size GiB | dims | run | render s | total s | wall s | peak RSS MiB | peak / bound |",
             "|---:|---|---|---:|---:|---:|---:|---:|"]
    for line in lines:
        say(line)
    notes = []
    for gib in sizes:
        start = time.perf_counter()
        volume = volume_file(folder, gib)
        written = time.perf_counter() - start
        for sidecar in folder.glob(volume.stem + "*.dvr-ranges.npz"):
            sidecar.unlink()  # the first run computes the block ranges
        for run_name in ("first", "again"):
            m = measured(render_command(volume, out, memory_mb, texture_mb, image))
            dims = "x".join(map(str, dims_for(gib)))
            row = (f"| {gib:g} | {dims} | {run_name} | {m['render']:.2f} | {m['total']:.2f} | {m['wall']:.1f} | "
                   f"{m['peak_mib']:.0f} | {m['peak_mib'] / bound:.2f} |")
            lines.append(row)
            say(row)
        if written > 1:
            notes.append(f"the {gib:g} GiB file was written in {written:.0f} s")
    if notes:  # after the table, which they would break
        say("")
        say("; ".join(notes) + ".")
    return "\n".join(lines)
