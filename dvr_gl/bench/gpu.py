"""``dvr bench gpu``: every renderer's frame time at GPU sizes, within a time budget, with the device named.

Made for the first session lent a real GPU (docs/gpu.md): one command that records, in a few minutes, the frame
time of every renderer the registry lists for grids, tetrahedral meshes and SPH particles (asked by declared data
kind; the CPU float64 judges, which declare ``reference``, are listed and left out), and of the peers (VTK's GPU
ray caster, vispy) where their environment is installed, and writes a Markdown table and a JSON file.

The data, at full size (``--volume-size N``, default 512; ``--size`` pixels a side, default 1024):

* grid: the Shepp-Logan demo on N^3 nodes (or ``--volume FILE``), the demo's transfer function, unshaded;
* mesh: the Shepp-Logan phantom on M^3 points (default M = N/16 + 1) over the same box, its hexahedra split into
  12 tetrahedra each (393,216 tetrahedra at N = 512), the same transfer function, alpha per grid voxel;
* particles: the Plummer demo of (N/2)^3 particles, at most 10^6, with its transfer function.

Every renderer runs at its defaults, seen from azimuth 30, elevation 20, framed, perspective; where a renderer
declares that it does not take one of the model's defaults (a projection, a setting's value), its first declared
choice instead (:func:`fitted`), named in the row.

Time is budgeted (``--time-budget`` seconds, the whole bench included: making the data, compiling, uploading):
each case (a renderer on a kind of data) climbs a ladder of sizes, a quarter, half and the full data side and
image side; the quarter runs twice, a warm-up (compiling, JIT) and then measured.  Before each larger step the
step's time is predicted from the last one, times at least :data:`GROWTH` (twice the side and twice the image:
8 times the voxels, 4 times the pixels, twice the samples a ray) or the growth measured between the last two
steps if larger, plus, where the step's data is not made yet, 8 times the last data's making shared among the
cases of that kind still to run.  A step predicted to overrun the case's share of what is left (what is left
over the cases left) is not run, and the row says at which size it stopped and why; a step that runs past what
is left of its share anyway is stopped by a timer (its row keeps the step before, and says so); a case reached
when nothing is left is skipped, saying so.  The files are written only at the end, both or neither.

Columns: "first frame s" is the first render's wall time (the renderer and its context made, programs compiled,
data uploaded); "frame ms" the median wall time of ``--frames`` renders after it (the image read back: the GPU
finished); "GPU draw ms" the draw calls to ``glFinish`` where the renderer reports them (``stats["gpu_seconds"]``).
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import os
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from . import tick, volume_keys

KINDS = ("grid", "mesh", "particles")
FRACTIONS = (0.25, 0.5, 1.0)  # the ladder: a quarter (the warm-up), half, the full side of data and image
GROWTH = 8.0  # the least time ratio assumed from one step to the next (8x the voxels, 4x the pixels)
WARM_UP_LIMIT = 60.0  # seconds the first step of a case may take, whatever its share (it is not predicted)
MIN_NODES, MIN_IMAGE, MIN_MESH_POINTS, MIN_PARTICLES = 8, 16, 3, 64
MAX_PARTICLES = 10 ** 6
PEERS = ("vtk-gpu", "vispy")  # dvr_gl.bench.peers' names of the GPU peers
PEER_SCENE = "ml-composite"  # dvr_gl.bench.peers.SCENES: Marschner-Lobb, emission-absorption (a test checks)
PEER_DEMO, PEER_MODE = "marschner-lobb", "composite"
FILES = ("gpu-bench.md", "gpu-bench.json")
VIEW = {"camera.azimuth": 30.0, "camera.elevation": 20.0}

COLUMNS = [("data", "data", ""), ("renderer", "renderer", ""), ("size", "size", ""), ("image", "image", ""),
           ("first_s", "first frame s", ".2f"), ("frame_ms", "frame ms", ".1f"), ("gpu_ms", "GPU draw ms", ".1f"),
           ("fps", "frames/s", ".1f"), ("settings", "not the defaults", ""), ("note", "note", "")]


@dataclass(frozen=True)
class Step:
    """One rung of a case's ladder: ``data`` nodes a side (grid; None: the ``--volume`` file as it is), points
    a side (mesh) or particles (particles); ``image`` pixels a side."""

    kind: str
    data: int | None
    image: int

    def size(self, field=None) -> str:
        if self.kind == "grid":
            return f"{self.data}^3" if self.data else "x".join(map(str, field.dims)) if field else "the file"
        if self.kind == "mesh":
            return f"{12 * (self.data - 1) ** 3:,} tetrahedra"
        return f"{_plummer_count(self.data):,} particles"


def steps(kind: str, args) -> list[Step]:
    """The ladder of ``kind``'s sizes, smallest first, without repeats."""
    n = args.volume_size
    out = []
    for f in FRACTIONS:
        image = max(MIN_IMAGE, round(args.size * f))
        if kind == "grid":
            data = None if args.volume else max(MIN_NODES, round(n * f))
        elif kind == "mesh":
            data = max(MIN_MESH_POINTS, round((mesh_points(args) - 1) * f) + 1)
        else:
            data = max(MIN_PARTICLES, round(particles(args) * f ** 3))
        step = Step(kind, data, image)
        if step not in out:
            out.append(step)
    return out


def mesh_points(args) -> int:
    """The mesh's points a side at full size (``--mesh-size``, default N/16 + 1)."""
    return args.mesh_size or max(MIN_MESH_POINTS, args.volume_size // 16 + 1)


def particles(args) -> int:
    """The particles at full size (``--particles``, default (N/2)^3, at most 10^6)."""
    return args.particles or min(MAX_PARTICLES, max(1, args.volume_size // 2) ** 3)


def _plummer_size(count: int) -> int:
    """The Plummer demo's ``volume.size`` for about ``count`` particles (it makes (size/2)^3)."""
    return max(2, 2 * round(count ** (1.0 / 3.0)))


def _plummer_count(count: int) -> int:
    return (_plummer_size(count) // 2) ** 3


# --- the data ------------------------------------------------------------------------------------

class Data:
    """Each step's field, made once and shared by the renderers (the biggest lives until the bench ends)."""

    def __init__(self, args):
        self.args, self.fields = args, {}
        self.making: dict[str, float] = {}  # kind: seconds its last field took to make
        self.made_s = 0.0  # seconds spent making fields, in all

    def field(self, step: Step):
        key = (step.kind, step.data)
        if key not in self.fields:
            self.fields = {k: v for k, v in self.fields.items() if k[0] == step.kind}  # one kind at a time
            start = time.perf_counter()
            self.fields[key] = getattr(self, f"_{step.kind}")(step.data)
            self.making[step.kind] = time.perf_counter() - start
            self.made_s += self.making[step.kind]
        return self.fields[key]

    def predicted_making(self, step: Step, sharing: int) -> float:
        """Seconds of making ``step``'s field charged to one of the ``sharing`` cases of its kind still to run
        (none if made already): :data:`GROWTH` times the last field of its kind, shared among them."""
        if (step.kind, step.data) in self.fields or step.kind not in self.making:
            return 0.0
        return GROWTH * self.making[step.kind] / max(sharing, 1)

    def scene(self, step: Step, renderer: str):
        """The scene of ``renderer`` at ``step`` (the field made once), and the settings changed from the
        model's defaults to ones it declares (:func:`fitted`)."""
        scene = self._scene(step, renderer, {})
        changes = fitted(scene)
        return (self._scene(step, renderer, changes) if changes else scene), changes

    def _scene(self, step: Step, renderer: str, changes: dict):
        from ..phantoms import SHEPP_LOGAN_DEMO_POINTS, demo_scene
        from ..scene.resolve import apply_overrides, parse_scene, resolve_scene

        keys = {"image.width": step.image, "image.height": step.image, "renderer.name": renderer, **VIEW, **changes}
        if step.kind == "particles":
            keys["transfer_function.points"] = demo_scene("plummer")["transfer_function"]["points"]
        elif not (step.kind == "grid" and self.args.volume):
            keys.update({"transfer_function.points": SHEPP_LOGAN_DEMO_POINTS, "transfer_function.unit_distance": 1.0,
                         "renderer.shading.enabled": False})
        spec = parse_scene(apply_overrides({}, keys), "dvr bench gpu")
        return resolve_scene(spec, field=self.field(step))

    def _grid(self, n):
        from ..scene.resolve import load_scene

        return load_scene(None, volume_keys(self.args.volume, n)[0]).field

    def _mesh(self, m):
        """The Shepp-Logan phantom on ``m``^3 points over the grid's box (N - 1 world units a side)."""
        import numpy as np

        from ..fields.mesh import TetMesh
        from ..fields.mesh_cells import hexahedra_of_grid, tetrahedralize
        from ..phantoms import shepp_logan

        half = (self.args.volume_size - 1) / 2.0
        axis = np.linspace(-half, half, m)
        z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")  # x fastest, as hexahedra_of_grid numbers them
        points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
        points, tets, _, values = tetrahedralize(points, [("hexahedron", hexahedra_of_grid(m, m, m))],
                                                 shepp_logan(m).astype(np.float64).ravel())
        return TetMesh(points, tets, values, name=f"shepp-logan-{m}")

    def _particles(self, count):
        from ..phantoms import demo_volume

        return demo_volume("plummer", _plummer_size(count))


def run(args) -> int:
    """The bench (module doc): check, measure, print, then write both files."""
    import tempfile

    from . import peers

    paths = check_out(args)
    check_arguments(args)
    start = time.perf_counter()
    clock = lambda: time.perf_counter() - start  # noqa: E731
    dev = device()
    todo, left = cases()
    python = args.peers_python or peers.default_peers_python()
    names, notes = available_peers(python) if not args.no_peers else ([], ["peers: not run (--no-peers)"])
    report = args.report
    report.text(f"dvr bench gpu on {dev['GL_RENDERER']} ({dev['GL_VERSION']})"
                + (f"; nvidia-smi: {dev['nvidia_smi']}" if dev["nvidia_smi"] else ""))
    grid = volume_keys(args.volume, args.volume_size)[1]
    report.text(f"grid: {grid}; mesh: {Step('mesh', mesh_points(args), 0).size()}; particles: "
                f"{Step('particles', particles(args), 0).size()}; {args.size}x{args.size}, azimuth 30, elevation 20, "
                f"each renderer at its defaults (or its first declared choice where it does not take the model's "
                f"default: column 'not the defaults'); median of {args.frames} frames after the first; time budget "
                f"{args.time_budget:g} s (sizes a quarter and half first: docs/gpu.md)")
    rows = left + run_cases(args, Data(args), todo, clock, 1 + len(names) if names else 0)
    peer_rows = []
    if names:
        with tempfile.TemporaryDirectory(prefix="dvr-gpu-peers-") as work:
            peer_rows = run_peers(args, names, python, clock, Path(work))
    elapsed = clock()
    report.text()
    report.table(rows, COLUMNS)
    if peer_rows:
        report.text()
        report.text(f"peers on {PEER_SCENE} (Marschner-Lobb, emission-absorption; fresh processes, the worker of "
                    f"dvr bench peers; dvr-gl at its defaults, the peers at one sample a voxel)")
        report.table(peer_rows, [c for c in COLUMNS[1:] if c[0] != "settings"])
    for note in notes:
        report.text(note)
    report.text(f"measured in {elapsed:.0f} s of a {args.time_budget:g} s budget")
    write_both(paths, [report.markdown(args.command_line),
                       record(args, dev, _finite(rows), _finite(peer_rows), notes, elapsed)], args.overwrite)
    for path in paths:
        print(f"wrote {path}")
    return 0


def check_arguments(args):
    """One line naming a flag out of range."""
    from ..errors import DvrError

    for flag, value, low, high in (("--volume-size", args.volume_size, MIN_NODES, 1024),
                                   ("--size", args.size, MIN_IMAGE, 8192),
                                   ("--mesh-size", args.mesh_size, MIN_MESH_POINTS, 129),
                                   ("--particles", args.particles, MIN_PARTICLES, 10 ** 7)):
        if value is not None and not low <= value <= high:
            raise DvrError(f"{flag} must be {low} to {high}, got {value}")
    if not (0 < args.time_budget <= 3600):
        raise DvrError(f"--time-budget must be above 0 and at most 3600 seconds, got {args.time_budget:g}")
    if args.volume and not Path(args.volume).exists():
        raise DvrError(f"--volume {args.volume}: no such file")
    if args.peers_python and not Path(args.peers_python).exists():
        raise DvrError(f"--peers-python {args.peers_python}: no such interpreter")


def fitted(scene) -> dict:
    """Scene keys for what the scene's renderer declares it does not take at the model's defaults: a camera
    projection it does not render (its first declared one instead: Fourier rendering's orthographic view) and a
    setting value outside its declared choices (its first choice: splatting's kernel instead of the trilinear
    filter).  Empty when it takes the defaults."""
    from ..renderers import registry

    p = registry.plugin(scene.renderer.name)
    keys = {}
    if scene.camera.projection not in p.projections:
        keys["camera.projection"] = p.projections[0]
    for s in p.settings:
        value = getattr(scene.renderer, s.name, None)
        if s.choices and isinstance(value, str) and value not in s.choices:
            keys[f"renderer.{s.name}"] = s.choices[0]
    return keys


# --- the measurement -----------------------------------------------------------------------------

def cases() -> tuple[list[tuple[str, str]], list[dict]]:
    """(kind, renderer) for every renderer the registry lists for each kind, in its order; and the rows of the
    judges (``reference``: CPU float64, minutes a frame at these sizes), left out."""
    from ..renderers import registry

    todo, left = [], []
    for kind in KINDS:
        for name in registry.renderers_with(lambda p: p.data_kinds is None or kind in p.data_kinds):
            if registry.plugin(name).reference:
                left.append({"data": kind, "renderer": name, "note": "left out: a CPU float64 judge (reference), "
                                                                    "not a GPU frame"})
            else:
                todo.append((kind, name))
    return todo, left


def measure(name: str, scene, frames: int) -> dict:
    """First render (context, programs, upload) and the median of ``frames`` renders after it."""
    from ..renderers import create_renderer

    start = time.perf_counter()
    with create_renderer(name) as renderer:
        renderer.render(scene)
        first = time.perf_counter() - start
        walls, draws = [], []
        for _ in range(frames):
            t = time.perf_counter()
            renderer.render(scene)
            walls.append(time.perf_counter() - t)
            if renderer.stats.get("gpu_seconds") is not None:
                draws.append(renderer.stats["gpu_seconds"])
            tick()
    frame = statistics.median(walls)
    return {"first_s": first, "frame_ms": 1e3 * frame, "fps": 1.0 / frame if frame > 0 else None,
            "gpu_ms": 1e3 * statistics.median(draws) if draws else None}


class Overrun(BaseException):
    """A step ran past the time left to it (a BaseException, as KeyboardInterrupt: no renderer's handler of
    errors takes it for one of its own)."""


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise :class:`Overrun` after ``seconds`` of wall time (in the main thread, where there is an interval
    timer; elsewhere no limit)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield
        return

    def expire(signum, frame):
        raise Overrun()

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, max(seconds, 1e-3))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def climb(ladder: list[Step], share: float, run_step, describe, making=lambda step: 0.0) -> tuple[dict, float]:
    """Run ``run_step(step) -> dict`` up ``ladder`` while each next step is predicted to fit in ``share``
    seconds (module doc); the last step's numbers, a note where it stopped short, and the seconds spent.
    The first step runs twice: a warm-up (what is paid once a process: compiling, numba's JIT, caches), then
    measured.  ``making(step)``: the predicted seconds of making the step's data charged to this case; a
    result's ``making_s``, the seconds it spent making data, is left out of the growth of the renderer's own
    time.  A step that runs past what is left of the share (the first: at least :data:`WARM_UP_LIMIT`
    seconds) is stopped, and the row keeps the step before it."""
    row, spent, last = {}, 0.0, None
    growth = GROWTH
    for k, step in enumerate(ladder[:1] + list(ladder)):
        left = share - spent
        if last is not None:
            predicted = growth * last + making(step)
            if predicted > left:
                row["note"] = (f"shrunk: {describe(step)} predicted {predicted:.1f} s, over the {max(left, 0.0):.1f} "
                               f"s left of its share of the time budget")
                break
        result, note, elapsed = _attempt(run_step, step, left if last is not None else max(left, WARM_UP_LIMIT),
                                         describe)
        spent += elapsed
        if note is not None:
            row["note"] = note
            break
        if k == 0:  # the warm-up
            continue
        cost = max(elapsed - result.pop("making_s", 0.0), 1e-6)
        if last is not None:
            growth = max(GROWTH, cost / last)
        last = cost
        row = {**result, "note": None}
    return row, spent


def _attempt(run_step, step, limit: float, describe) -> tuple[dict | None, str | None, float]:
    """``run_step(step)`` within ``limit`` seconds: its result, or a note why there is none (stopped, failed,
    refused); and the seconds it took."""
    start = time.perf_counter()
    try:
        with time_limit(limit):
            result = run_step(step)
    except Overrun:
        return None, (f"stopped: {describe(step)} ran past the {limit:.1f} s left of its share of the time "
                      f"budget"), time.perf_counter() - start
    except Exception as exc:  # a bench records what failed (out of GPU memory, a limit) and goes on
        message = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return None, f"failed at {describe(step)}: {message}", time.perf_counter() - start
    return result, result.get("note"), time.perf_counter() - start  # a note: refused, no larger step does better


def run_cases(args, data: Data, todo, clock, reserve: int) -> list[dict]:
    """One row per (kind, renderer), each with its share of what is left of the budget (``reserve``: the peers'
    cases still to come)."""
    from ..renderers import registry

    rows = []
    for i, (kind, name) in enumerate(todo):
        left = args.time_budget - clock()
        base = {"data": kind, "renderer": name}
        if left <= 0:
            rows.append({**base, "note": f"skipped: the {args.time_budget:g} s time budget was spent"})
            continue

        def run_step(step, name=name):
            before = data.made_s
            scene, changes = data.scene(step, name)
            refused = registry.refusal(scene)
            if refused:
                return {"note": f"refused: {refused}"}
            return {"size": step.size(scene.field), "image": f"{step.image}x{step.image}",
                    "settings": ", ".join(f"{k} = {v}" for k, v in changes.items()) or None,
                    **measure(name, scene, args.frames), "making_s": data.made_s - before}

        sharing = sum(1 for k, _ in todo[i:] if k == kind)
        row, _ = climb(steps(kind, args), left / (len(todo) - i + reserve), run_step,
                       lambda s: f"{s.size()} at {s.image}x{s.image}", lambda s: data.predicted_making(s, sharing))
        rows.append({**base, **row})
        print(_progress_line(rows[-1]), flush=True)
    return rows


def _progress_line(row: dict) -> str:
    if row.get("frame_ms") is None:
        return f"{row['data']} {row['renderer']}: {row.get('note')}"
    return (f"{row['data']} {row['renderer']} {row['size']} at {row['image']}: first {row['first_s']:.2f} s, "
            f"frame {row['frame_ms']:.1f} ms" + (f" ({row['note']})" if row.get("note") else ""))


# --- the peers -----------------------------------------------------------------------------------

def available_peers(python: str | None) -> tuple[list[str], list[str]]:
    """The GPU peers importable in ``python`` ("name version"), and notes for the rest."""
    from . import peers

    have, missing = peers.available(python, PEERS)
    return list(have), [f"{r}: {why}" for r, why in missing.items()]


def run_peers(args, names: list[str], python: str, clock, work: Path) -> list[dict]:
    """dvr-gl's defaults, then each peer, on :data:`PEER_SCENE` (fresh processes, ``dvr bench peers``' worker),
    up the same ladder of grid sizes."""
    rows = []
    configs = [("dvr-gl", sys.executable)] + [(n, python) for n in names]
    grid = [Step("grid", max(MIN_NODES, round(args.volume_size * f)), max(MIN_IMAGE, round(args.size * f)))
            for f in FRACTIONS]
    files: dict[int, float] = {}  # the volume files written: nodes a side -> seconds to make
    for i, (name, interpreter) in enumerate(configs):
        left = args.time_budget - clock()
        if left <= 0:
            rows.append({"data": PEER_SCENE, "renderer": name, "note": "skipped: the time budget was spent"})
            continue
        case = PeerCase(args, name, interpreter, work, left / (len(configs) - i), files)
        row, _ = climb(list(dict.fromkeys(grid)), case.share, case.run_step,
                       lambda s: f"{s.data}^3 at {s.image}x{s.image}", case.making)
        rows.append({"data": PEER_SCENE, "renderer": name, **row})
        print(_progress_line(rows[-1]), flush=True)
    return rows


class PeerCase:
    """One peer's runs: each step a fresh process, whose start and first frame (importing the peer, its context,
    the upload) hardly grow with the size on a GPU: they are left out of the growth and predicted as they were
    (``making``; a step that overruns its share anyway is stopped at it, and says so), with the volume file's
    making where the step's file is not written yet (``files``, shared by the cases: nodes a side -> seconds)."""

    def __init__(self, args, name: str, python: str, work: Path, share: float, files: dict):
        self.args, self.name, self.python, self.work, self.share, self.files = args, name, python, work, share, files
        self.process_s = 0.0

    def making(self, step: Step) -> float:
        last = self.files[max(self.files)] if self.files else 0.0
        return self.process_s + (0.0 if step.data in self.files else GROWTH * last)

    def run_step(self, step: Step) -> dict:
        from . import peers

        start = time.perf_counter()
        keys = peers.scene_keys(PEER_SCENE, peers.volume_file(PEER_DEMO, step.data, self.work), step.image)
        file_s = time.perf_counter() - start
        self.files.setdefault(step.data, file_s)
        result = peers.run_one({"renderer": self.name, "keys": {}}, peers.peer_scene(keys, PEER_MODE), keys,
                               self.python, step.image, self.args.frames, None,
                               self.work / f"{self.name}-{step.data}-{step.image}", timeout=max(self.share, 1.0))
        if "failed" in result or "unsupported" in result:
            raise RuntimeError(result.get("failed") or result["unsupported"])
        rendering = sum(result["seconds"])  # the timed frames; the rest (the start, the first frame) is kept as is
        self.process_s = max(time.perf_counter() - start - rendering - file_s, 0.0)
        frame = statistics.median(result["seconds"])
        return {"size": f"{step.data}^3 uint8", "image": f"{step.image}x{step.image}",
                "first_s": result["first_seconds"], "frame_ms": 1e3 * frame, "fps": 1.0 / frame if frame > 0 else None,
                "version": result.get("version"), "making_s": time.perf_counter() - start - rendering}


# --- the device and the files --------------------------------------------------------------------

def device() -> dict:
    """The GL device (renderer, version, vendor of a context made as the renderers make theirs) and
    nvidia-smi's line where there is one."""
    from ..gl.context import create_context, release_context

    ctx = create_context()
    try:
        out = {k: ctx.info.get(k) for k in ("GL_RENDERER", "GL_VERSION", "GL_VENDOR")}
    finally:
        release_context(ctx)
    out["nvidia_smi"] = _nvidia_smi()
    return out


def _nvidia_smi() -> str | None:
    smi = shutil.which("nvidia-smi")
    if smi is None:
        return None
    try:
        done = subprocess.run([smi, "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
                              capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    lines = done.stdout.strip().splitlines()
    return lines[0].strip() if done.returncode == 0 and lines else None


def check_out(args) -> list[Path]:
    """The two files' paths in ``--out`` (default ``$OUT``), checked before any work."""
    from ..errors import DvrError
    from ..image import check_writable

    folder = args.out or os.environ.get("OUT")
    if not folder:
        raise DvrError("give --out DIR, the folder for gpu-bench.md and gpu-bench.json (or set OUT)")
    if not Path(folder).is_dir():
        raise DvrError(f"--out {folder}: no such folder; create it first (mkdir -p {folder})")
    return [check_writable(Path(folder) / name, args.overwrite) for name in FILES]


def write_both(paths: list[Path], texts: list[str], overwrite: bool):
    """Both files or neither: each written to a temporary file beside it, renamed only when both are written."""
    from ..image import atomic_output

    with contextlib.ExitStack() as stack:
        temporary = [stack.enter_context(atomic_output(p, overwrite)) for p in paths]
        for tmp, text in zip(temporary, texts):
            tmp.write_text(text, encoding="utf-8")


def record(args, dev: dict, rows: list[dict], peer_rows: list[dict], notes: list[str], elapsed: float) -> str:
    """The JSON file's text."""
    from .. import __version__

    now = datetime.datetime.now(datetime.timezone.utc)
    return json.dumps({
        "command": args.command_line, "date": now.isoformat(timespec="seconds"),
        "device": dev, "platform": platform.platform(), "python": platform.python_version(), "dvr_gl": __version__,
        "settings": {"volume": args.volume, "volume_size": args.volume_size, "size": args.size,
                     "mesh_points": mesh_points(args), "particles": particles(args), "frames": args.frames,
                     "time_budget_s": args.time_budget},
        "elapsed_s": round(elapsed, 3), "rows": rows, "peers": peer_rows, "notes": notes},
        indent=1, default=str, allow_nan=False) + "\n"


def _finite(rows: list[dict]) -> list[dict]:
    return [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()} for r in rows]
