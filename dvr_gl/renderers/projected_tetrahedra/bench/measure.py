"""``dvr bench cells``: projected tetrahedra on the shared meshes, against the float64 mesh reference
and, where VTK is importable in the peers' environment, VTK's ``vtkProjectedTetrahedraMapper`` in
the same run.

For each mesh and view: dvr-gl's projected tetrahedra with the exact visibility order and both
integrations (``exact`` per fragment and ``shirley-tuchman``), and with the centroid order (each integration; frame
time, its order and draw parts, cells per second, one process: they share the mesh's upload and
adjacency, built by an untimed frame; their frames interleaved, A B C A B C, medians), then VTK
(``VTK ms / ms``: above 1, dvr-gl is faster), dvr-gl's ``cell-raycast`` (its defaults; no
order), the ray caster on the mesh resampled onto a grid of
:data:`RESAMPLE` points along its longest axis (its defaults; the resampling, once per mesh, not
timed).  VTK runs in a process of the peers' environment kept open beside dvr-gl's
(:mod:`.vtk_frames`), one frame in each round of projected tetrahedra's interleaved frames (A B C
A B C ...), and again in a fresh process (``peer_worker.py``, as ``dvr bench peers`` runs its
peers) for its picture at the error size; VTK sorts its cells again every frame, as dvr-gl does.
Each one's RMS error
against ``reference-converged`` at ``error_size``.  The transfer function is semi-transparent over
the scalar's range, its control values at the scalar's quintiles (the FE stresses are skewed: an
even spread leaves them invisible), alpha per a tenth of the mesh's diagonal.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ....bench import peers, picks
from ....bench.datasets import MESHES
from ....bench.datasets import mesh_scene_keys as scene_keys
from ....progress import task as progress_task

VIEWS = ((30.0, 20.0), (120.0, -10.0), (0.0, 90.0))  # azimuth, elevation


def view_keys(keys: dict, azimuth: float, elevation: float, size: int) -> dict:
    """A mesh's scene ``keys`` seen from ``azimuth``, ``elevation`` (degrees) by projected tetrahedra in a
    ``size`` x ``size`` image: one of this bench's views (and its A/B scripts', ``benchmarks/``)."""
    return {**keys, "camera.azimuth": azimuth, "camera.elevation": elevation,
            "renderer.name": "projected-tetrahedra", "image.width": size, "image.height": size}


def view_scenes(meshes, data_dir, size: int):
    """Each shared mesh of ``meshes`` (names) from ``data_dir`` seen from each of :data:`VIEWS` in a ``size`` x
    ``size`` image: ``(mesh, azimuth, elevation, scene)``, mesh by mesh (the A/B scripts' loop, ``benchmarks/``)."""
    from ....bench.datasets import shared_mesh
    from ....scene.resolve import load_scene

    for name in meshes:
        keys, _ = shared_mesh(name, data_dir)
        for azimuth, elevation in VIEWS:
            yield name, azimuth, elevation, load_scene(None, view_keys(keys, azimuth, elevation, size))
RESAMPLE = 128  # grid points along the longest axis for the resampled ray-casting rows
COLUMNS = [("mesh", "mesh", ""), ("view", "view", ""), ("renderer", "renderer", ""), ("cells", "cells", ""),
           ("order_ms", "order ms", ".0f"), ("draw_ms", "draw ms", ".0f"), ("ms", "frame ms", ".0f"),
           ("mtets", "M cells/s", ".3f"), ("rms", "RMS", ".2e"), ("vs_vtk", "VTK ms / ms", ".2f"),
           ("cycles", "cycles broken", "")]
#: projected tetrahedra's cases, timed interleaved: label, renderer settings.  The last pairs VTK's own order (cell
#: centres' depth, ``vtkCellCenterDepthSort``) with the Shirley-Tuchman fan: VTK's algorithm, ours.
CASES = (("dvr-gl exact", {"cell_order": "exact"}),
         ("dvr-gl shirley-tuchman", {"cell_order": "exact", "integration": "shirley-tuchman"}),
         ("dvr-gl centroid", {"cell_order": "centroid"}),
         ("dvr-gl shirley-tuchman centroid", {"cell_order": "centroid", "integration": "shirley-tuchman"}))
#: ``--only-pt``: both integrations in the exact order, and VTK's algorithm
ONLY_PT = ("dvr-gl exact", "dvr-gl shirley-tuchman", "dvr-gl shirley-tuchman centroid")


def write_vtu(mesh, path: Path):
    """The mesh's tetrahedra and scalar (``scalars``) as a ``.vtu`` for VTK."""
    import meshio

    data = ({"point_data": {"scalars": mesh.values}} if mesh.association == "point"
            else {"cell_data": {"scalars": [mesh.values]}})
    meshio.write(str(path), meshio.Mesh(mesh.points, [("tetra", mesh.tets)], **data))


def _timed(renderer, scene, frames: int) -> dict:
    renderer.render(scene)  # upload, programs, adjacency: untimed
    stats = []
    for _ in range(frames):
        renderer.render(scene)
        stats.append(dict(renderer.stats))
    middle = sorted(stats, key=lambda s: s["seconds"])[len(stats) // 2]
    part = lambda key: 1e3 * middle[key] if key in middle else None  # noqa: E731
    return {"ms": 1e3 * statistics.median(s["seconds"] for s in stats), "order_ms": part("order_seconds"),
            "draw_ms": part("draw_seconds"), "cycles": middle.get("cycles_broken", "")}


class _VtkFrames:
    """VTK's frames one at a time from a process of the peers' environment (:mod:`.vtk_frames`), to
    take in turn with dvr-gl's.  ``frame()`` returns its seconds; ``failed`` says why there are none
    (then the fresh process's frames are used, as before)."""

    def __init__(self, python: str, job_scene: dict, size: int, folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "scene.json").write_text(json.dumps(job_scene, default=float))
        self.failed = None
        self._log = open(folder / "vtk_frames.log", "w")  # noqa: SIM115 (closed in close())
        self._proc = subprocess.Popen([python, str(Path(__file__).with_name("vtk_frames.py")),
                                       str(folder / "scene.json"), str(size)],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log, text=True)
        if self._proc.stdout.readline().strip() != "ready":
            self.failed = f"VTK's interleaved frames did not start (see {folder / 'vtk_frames.log'})"

    def frame(self) -> float | None:
        if self.failed:
            return None
        try:
            self._proc.stdin.write("frame\n")
            self._proc.stdin.flush()
            return float(self._proc.stdout.readline())
        except (OSError, ValueError) as exc:
            self.failed = f"VTK's interleaved frames stopped: {exc}"
            return None

    def close(self):
        try:
            self._proc.stdin.close()
            self._proc.wait(timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            self._proc.kill()
        self._log.close()


def _interleaved(renderer, scenes: list, frames: int, beside=None) -> list[dict]:
    """:func:`_timed` for several scenes, their frames taken in turn (A B A B ...), one row each;
    ``beside``: a peer's frame (:class:`_VtkFrames`) taken in each round too, its seconds in
    ``beside.seconds``."""
    for scene in scenes:
        renderer.render(scene)  # upload, programs, adjacency: untimed
    stats = [[] for _ in scenes]
    if beside is not None:
        beside.seconds = []
    for _ in range(frames):
        for i, scene in enumerate(scenes):
            renderer.render(scene)
            stats[i].append(dict(renderer.stats))
        if beside is not None:
            seconds = beside.frame()
            if seconds is not None:
                beside.seconds.append(seconds)
    rows = []
    for runs in stats:
        middle = sorted(runs, key=lambda s: s["seconds"])[len(runs) // 2]
        part = lambda key: 1e3 * middle[key] if key in middle else None  # noqa: E731
        rows.append({"ms": 1e3 * statistics.median(s["seconds"] for s in runs), "order_ms": part("order_seconds"),
                     "draw_ms": part("draw_seconds"), "cycles": middle.get("cycles_broken", "")})
    return rows


def _rms(image, truth) -> float:
    return float(np.sqrt(np.mean((np.asarray(image, np.float64) - truth) ** 2)))


def run(names, data_dir: Path, size: int = 512, error_size: int = 256, frames: int = 3, python: str | None = None,
        views=VIEWS, progress=None, timeout: float = 1800.0, pictures: Path | None = None, only_pt: bool = False):
    """Rows (one per mesh, view and renderer) and notes.  ``only_pt``: projected tetrahedra in the
    exact order, both integrations, Shirley-Tuchman in VTK's centroid order, and VTK (no cell-raycast, no
    resampling).
    ``pictures``: a folder for ``cells-MESH.png`` (the first view at the error size: the reference,
    dvr-gl exact and shirley-tuchman, cell-raycast, resampled ray casting and VTK where measured,
    above 5x their differences from the reference)."""
    from ....fields.mesh_resample import resample
    from ....scene.resolve import load_scene
    from ... import create_renderer

    have, missing = peers.available(python, ["vtk-pt"])
    notes = [f"vtk-pt: {why}" for why in missing.values()]
    rows = []
    work = tempfile.TemporaryDirectory(prefix="dvr-cells-")
    pt = create_renderer("projected-tetrahedra")
    # beside it: the other GL mesh renderers (cell-raycast) on its context, the default grid renderer (the ray
    # caster) on the mesh resampled, all against the converged reference
    walkers = [] if only_pt else [create_renderer(n, ctx=pt.ctx) for n in picks.renderers(kind="mesh", gl=True)
                                  if n != pt.name]
    raycast = None if only_pt else create_renderer(picks.baseline("grid"))
    reference = create_renderer(picks.converged())
    try:
        for name in names:
            source, array = MESHES[name]
            path = Path(data_dir) / source
            if not path.exists():
                notes.append(f"{name}: {path} not found (--data-dir), left out")
                continue
            mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
            keys = scene_keys(path, array, mesh)
            grid = None if only_pt else resample(mesh, RESAMPLE)
            vtu = Path(work.name) / f"{name}.vtu"
            if have:
                write_vtu(mesh, vtu)
            for az, el in views:
                view = f"{az:g}/{el:g}"
                scene = load_scene(None, view_keys(keys, az, el, size))
                small = load_scene(None, view_keys(keys, az, el, error_size))
                with progress_task("converged reference", unit="step") as step:
                    reference.progress = step
                    truth = reference.render(small.with_renderer(name=reference.name)).astype(np.float64)
                tiles = [truth]
                cases = [c for c in CASES if c[0] in ONLY_PT] if only_pt else CASES
                vtk = _VtkFrames(python, _vtk_scene(scene, vtu), size,
                                 Path(work.name) / f"{name}-{az:g}-{el:g}-frames") if have else None
                try:
                    timed = _interleaved(pt, [scene.with_renderer(**keys_) for _, keys_ in cases], frames, vtk)
                finally:
                    if vtk is not None:
                        vtk.close()
                if vtk is not None and vtk.failed:
                    notes.append(f"{name} {view}: {vtk.failed}; VTK's frames from its fresh process")
                first = len(rows)
                for (label, keys_), times in zip(cases, timed):
                    row = {"mesh": name, "view": view, "renderer": label, "cells": len(mesh.tets), **times}
                    row["mtets"] = row["cells"] / row["ms"] / 1e3
                    image = pt.render(small.with_renderer(**keys_))
                    row["rms"] = _rms(image, truth)
                    if "centroid" not in label:
                        tiles.append(image)
                    rows.append(row)
                    if progress:
                        progress(row)
                for walk in walkers:
                    row = {"mesh": name, "view": view, "renderer": f"dvr-gl {walk.name}", "cells": len(mesh.tets),
                           **_timed(walk, scene.with_renderer(name=walk.name), frames)}
                    row["mtets"] = row["cells"] / row["ms"] / 1e3
                    image = walk.render(small.with_renderer(name=walk.name))
                    row["rms"] = _rms(image, truth)
                    tiles.append(image)
                    rows.append(row)
                    if progress:
                        progress(row)
                if not only_pt:
                    tiles.append(_resampled_row(rows, raycast, name, view, mesh, scene, small, grid, frames, truth,
                                                progress))
                if have:
                    beside = vtk.seconds if vtk is not None and len(vtk.seconds) == frames else None
                    rows.append(_vtk_row(name, view, mesh, scene, vtu, python, size, error_size, frames, truth,
                                         Path(work.name) / f"{name}-{az:g}-{el:g}", timeout, notes, beside))
                    if rows[-1]:
                        tiles.append(rows[-1].pop("image"))
                        for row in rows[first:-1]:
                            row["vs_vtk"] = rows[-1]["ms"] / row["ms"]
                        if progress:
                            progress(rows[-1])
                if pictures is not None and (az, el) == tuple(views[0]):
                    _picture(Path(pictures) / f"cells-{name}.png", tiles)
        return [r for r in rows if r], notes
    finally:
        for walk in walkers:
            walk.close()
        pt.close()
        if raycast is not None:
            raycast.close()
        work.cleanup()


def against_vtk(rows: list[dict]) -> list[str]:
    """One line per dvr-gl case measured beside VTK: on how many views it is at least as fast (``VTK ms / ms``
    at least 1), the range of that ratio, and of VTK's RMS over its own (above 1: dvr-gl more accurate)."""
    vtk = {(r["mesh"], r["view"]): r for r in rows if r["renderer"].startswith("vtk-pt")}
    lines = []
    for label in dict.fromkeys(r["renderer"] for r in rows if r.get("vs_vtk") is not None):
        mine = [r for r in rows if r["renderer"] == label and r.get("vs_vtk") is not None]
        speed = [r["vs_vtk"] for r in mine]
        error = [vtk[r["mesh"], r["view"]]["rms"] / r["rms"] for r in mine if r["rms"] > 0]
        lines.append(f"{label}: at least as fast as VTK on {sum(s >= 1.0 for s in speed)} of {len(speed)} views "
                     f"({min(speed):.2f}-{max(speed):.2f}x)"
                     + (f", VTK's RMS {min(error):.3g}-{max(error):.3g}x its own" if error else ""))
    return lines


def _resampled_row(rows, raycast, name, view, mesh, scene, small, grid, frames, truth, progress):
    """The ray caster on the resampled mesh: its row (appended) and image."""
    from ....fields.mesh_resample import resampled_scene

    rs = resampled_scene(scene, RESAMPLE, grid, name=raycast.name)
    raycast.render(rs)
    seconds = []
    for _ in range(frames):
        raycast.render(rs)
        seconds.append(raycast.stats["seconds"])
    ms = 1e3 * statistics.median(seconds)
    image = raycast.render(resampled_scene(small, RESAMPLE, grid, name=raycast.name))
    rows.append({"mesh": name, "view": view, "renderer": f"{raycast.name}, resampled {RESAMPLE}",
                 "cells": len(mesh.tets), "order_ms": None, "draw_ms": None, "ms": ms,
                 "mtets": len(mesh.tets) / ms / 1e3, "cycles": "", "rms": _rms(image, truth)})
    if progress:
        progress(rows[-1])
    return image


def _vtk_scene(scene, vtu: Path) -> dict:
    """The peer worker's scene for ``vtk-pt``: the mesh's file, transfer function, camera, depth range."""
    from ....gl.geometry import clip_planes

    cam = scene.camera
    return {"mesh": str(vtu), "transfer_function": scene.transfer_function.points.tolist(),
            "unit_distance": scene.transfer_function.unit_distance,
            "camera": {"eye": list(cam.eye), "target": list(cam.target), "up": list(cam.up), "fov": cam.fov},
            "clipping_range": list(clip_planes(cam, *scene.field.bounds))}


def _vtk_row(name, view, mesh, scene, vtu, python, size, error_size, frames, truth, folder, timeout, notes,
             seconds=None):
    """VTK's row: its picture at the error size from a fresh process, its frame time the median of
    ``seconds`` (its frames interleaved with dvr-gl's) where given, else of that process's frames."""
    res = peers.run_one({"renderer": "vtk-pt", "keys": {}}, _vtk_scene(scene, vtu), {}, python, size,
                        1 if seconds else frames, error_size, folder, timeout)
    if "failed" in res or "unsupported" in res:
        notes.append(f"{name} {view}: vtk-pt {res.get('failed') or res.get('unsupported')}")
        return None
    ms = 1e3 * statistics.median(seconds or res["seconds"])
    return {"mesh": name, "view": view, "renderer": f"vtk-pt {res.get('version', '')}".strip(), "cells": len(mesh.tets),
            "order_ms": None, "draw_ms": None, "ms": ms, "mtets": len(mesh.tets) / ms / 1e3,
            "rms": _rms(res["error"], truth), "cycles": "", "image": res["error"]}


def _picture(path: Path, tiles: list):
    """The reference and each image in a row, above 5x their differences from it (over black)."""
    from ....image import write_image

    truth = np.asarray(tiles[0], np.float64)
    top = np.concatenate([np.asarray(t, np.float64) for t in tiles], axis=1)
    bottom = np.concatenate([0 * truth] + [np.minimum(5 * np.abs(np.asarray(t, np.float64) - truth), 1.0)
                                           for t in tiles[1:]], axis=1)
    sheet = np.concatenate([top, bottom], axis=0).astype(np.float32)
    sheet[..., 3] = 1.0
    write_image(path, sheet, overwrite=True)
