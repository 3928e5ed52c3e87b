"""An end-to-end campaign against every input surface, as an attacker and a careless user would run it.

    python benchmarks/fuzz_campaign.py [--examples 300] [--seed 0] [--timeout 60] [--keep DIR]

Each case is one ``dvr render`` (or ``dvr info``) in a fresh process, on files written into a
case folder that is the only ``--sandbox`` root, beside an ``outside/`` folder the sandbox must
never read.  Three families:

* ``escape``: built escapes from the sandbox (a symlinked zarr chunk, ``.zarray``, ``.zattrs`` and
  ``zarr.json``, an OME dataset path with ``..``, an HDF5 external link, virtual dataset and
  external storage, a NRRD data file linked, named by ``..`` and by an absolute path, a DICOM
  member and a transfer-function file and a mesh linked out, absolute and ``..`` paths in a scene
  file). Each must exit 1 with one line and write nothing.
* ``mutated``: a small valid file of a format (grids, particles, zarr and OME-Zarr, meshes and
  surface geometry, transfer-function files, DICOM, ``.vti``), mutated at random (bytes set,
  inserted, cut; header values replaced by tokens of the wrong type or range), rendered at 32x32.
* ``settings``: absurd values of renderer settings and flags (sizes, widths, counts, limits) on a
  small volume or particle set, without ``--max-seconds``.

A run passes when it exits 0 with an image, or 1 with one line on stderr (progress bars aside), no
traceback, no partial output; a run past ``--timeout`` seconds passes only if it showed a progress
bar.  Exit 3 (internal error), any other status, a traceback, several lines, an escape that renders,
and a silent run past the timeout are findings: printed with the command that reproduces them.  The
script exits 1 if there was any finding.  The cases are drawn from ``--seed``; they are new on every
seed, and are not the cases the unit tests were written for.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))  # the byte and line mutations are shared with the tests

from dvr_gl.renderers import registry  # noqa: E402
from fuzz_inputs import mutate_bytes, mutate_lines  # noqa: E402
from judges import DISCRETE  # noqa: E402

DVR = [sys.executable, "-m", "dvr_gl"]
SIZE = ["--size", "32x32"]
DATA = (np.arange(4 * 3 * 2, dtype=np.int16).reshape(2, 3, 4) * 37 - 300)  # [z, y, x]


# --- small valid inputs ----------------------------------------------------------------------------

def _nrrd(folder: Path, name="v.nhdr", data_file="v.raw"):
    (folder / data_file).write_bytes(DATA.astype("<i2").tobytes())
    (folder / name).write_text("NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nspacings: 1 1 1\n"
                               f"endian: little\nencoding: raw\ndata file: {data_file}\n")
    return folder / name


def _zarr(folder: Path, ome: bool, version: int) -> Path:
    import zarr

    store = folder / "v.zarr"
    if ome:
        root = zarr.open_group(str(store), mode="w", zarr_format=version)
        root.create_array("0", shape=DATA.shape, chunks=(1, 3, 4), dtype="i2")[...] = DATA
        multiscales = [{"version": "0.4", "axes": [{"name": a, "type": "space"} for a in "zyx"],
                        "datasets": [{"path": "0", "coordinateTransformations": [
                            {"type": "scale", "scale": [2.0, 1.0, 0.5]}]}]}]
        if version == 3:
            root.attrs["ome"] = {"version": "0.5", "multiscales": multiscales}
        else:
            root.attrs["multiscales"] = multiscales
    else:
        arr = zarr.create_array(str(store), shape=DATA.shape, chunks=(1, 3, 4), dtype="i2", zarr_format=version)
        arr[...] = DATA
    return store


def _vti(folder: Path) -> Path:
    values = " ".join(map(str, DATA.ravel()))
    (folder / "v.vti").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian">\n'
        '<ImageData WholeExtent="0 3 0 2 0 1" Origin="0 0 0" Spacing="1 1 1">\n<Piece Extent="0 3 0 2 0 1">\n'
        f'<PointData Scalars="s">\n<DataArray type="Int16" Name="s" format="ascii">{values}</DataArray>\n'
        '</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n')
    return folder / "v.vti"


def _dicom(folder: Path) -> Path:
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    series = folder / "series"
    series.mkdir()
    uid = generate_uid()
    for k, plane in enumerate(DATA.astype(np.int16)):
        meta = FileMetaDataset()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID, ds.SOPInstanceUID = meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID
        ds.Modality, ds.SeriesInstanceUID, ds.InstanceNumber = "CT", uid, k + 1
        ds.Rows, ds.Columns, ds.SamplesPerPixel = plane.shape[0], plane.shape[1], 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.PixelSpacing, ds.SliceThickness = [0.5, 0.5], 1.0
        ds.ImagePositionPatient, ds.ImageOrientationPatient = [0.0, 0.0, float(k)], [1.0, 0, 0, 0, 1.0, 0]
        ds.RescaleSlope, ds.RescaleIntercept = 1, -1024
        ds.PixelData = plane.tobytes()
        ds.save_as(series / f"s{k}.dcm", enforce_file_format=True)
    return series


def _particles(folder: Path, kind: str) -> Path:
    rows = [[0, 0, 0, 1, 1, 2, 5], [1.5, 0, 0, 0.5, 2, 1, 6], [0, -1, 2, 1.25, 1, 0.5, 7]]
    if kind == "csv":
        text = "x,y,z,h,m,rho,u\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n"
        (folder / "p.csv").write_text(text)
        return folder / "p.csv"
    import h5py

    table = np.asarray(rows, float)
    with h5py.File(folder / "p.hdf5", "w") as f:
        gas = f.create_group("PartType0")
        gas["Coordinates"], gas["SmoothingLength"] = table[:, :3], 2 * table[:, 3]
        gas["Masses"], gas["Density"] = table[:, 4], table[:, 5]
    return folder / "p.hdf5"


def _vtu(folder: Path) -> Path:
    points = "0 0 0 1 0 0 0 1 0 0 0 1 1 1 1"
    (folder / "m.vtu").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">\n'
        '<UnstructuredGrid>\n<Piece NumberOfPoints="5" NumberOfCells="2">\n'
        f'<Points>\n<DataArray type="Float32" NumberOfComponents="3" format="ascii">{points}</DataArray>\n</Points>\n'
        '<Cells>\n<DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3 1 2 3 4</DataArray>\n'
        '<DataArray type="Int32" Name="offsets" format="ascii">4 8</DataArray>\n'
        '<DataArray type="UInt8" Name="types" format="ascii">10 10</DataArray>\n</Cells>\n'
        '<PointData Scalars="s">\n<DataArray type="Float32" Name="s" format="ascii">0 1 2 3 4</DataArray>\n'
        '</PointData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n')
    return folder / "m.vtu"


def _legacy_mesh(folder: Path) -> Path:
    (folder / "m.vtk").write_text(
        "# vtk DataFile Version 3.0\nmesh\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n"
        "0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1\nCELLS 1 9\n8 0 1 2 3 4 5 6 7\nCELL_TYPES 1\n12\n"
        "POINT_DATA 8\nSCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7\n")
    return folder / "m.vtk"


def _surface(folder: Path, suffix: str) -> Path:
    path = folder / f"s{suffix}"
    if suffix == ".obj":
        path.write_text("v 0 0 0\nv 3 0 0\nv 0 2 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n")
    elif suffix == ".ply":
        path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n3 0 0\n0 2 0\n3 0 1 2\n")
    else:
        path.write_text("solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 3 0 0\nvertex 0 2 0\n"
                        "endloop\nendfacet\nendsolid t\n")
    return path


def _vp(folder: Path) -> Path:
    (folder / "t.vp").write_text("1\n0\n0.9\n0.1\n0.2\n10\n6 -400 0 0 0.1 400 0.8\n4 0 1 255 1\n"
                                 "12 -400 0 0 0 0 1 0.5 0.2 400 1 1 1\n")
    return folder / "t.vp"


def _paraview(folder: Path) -> Path:
    maps = [{"Name": "t", "ColorSpace": "RGB", "RGBPoints": [-400, 0, 0, 0, 0, 1, 0.5, 0.2, 400, 1, 1, 1],
             "Points": [-400, 0, 0.5, 0, 400, 0.8, 0.5, 0]}]
    (folder / "t.json").write_text(json.dumps(maps))
    return folder / "t.json"


# --- the cases -------------------------------------------------------------------------------------

class Case:
    """A command to run in ``folder`` and what must hold: ``must_refuse`` (an escape)."""

    def __init__(self, family: str, name: str, folder: Path, args: list[str], must_refuse: bool = False):
        self.family, self.name, self.folder, self.args, self.must_refuse = family, name, folder, args, must_refuse


def _render(folder: Path, target, *extra) -> list[str]:
    return ["render", str(target), "-o", str(folder / "out.png"), *SIZE, "--sandbox", str(folder), *extra]


def escape_cases(make_folder) -> list[Case]:
    """Each escape, built in a fresh case folder; ``make_folder(name)`` gives (case folder, outside folder)."""
    cases = []

    def add(name, build, extra=()):
        folder, outside = make_folder(name)
        target, more = build(folder, outside)
        cases.append(Case("escape", name, folder, _render(folder, target, *extra, *more), must_refuse=True))

    def zarr_link(member, ome=False, version=2):
        def build(folder, outside):
            store, twin = _zarr(folder, ome, version), _zarr(outside, ome, version)
            for sub in [p for p in twin.rglob("*") if p.is_file() and p.relative_to(twin).as_posix() == member]:
                target = store / sub.relative_to(twin)
                target.unlink()
                target.symlink_to(sub)
            return store, ()
        return build

    add("zarr chunk linked out", zarr_link("0.0.0"))
    add("zarr .zarray linked out", zarr_link(".zarray"))
    add("zarr .zattrs linked out", zarr_link(".zattrs", ome=True))
    add("zarr v3 zarr.json linked out", zarr_link("zarr.json", version=3))
    add("zarr v3 chunk linked out", zarr_link("c/0/0/0", version=3))

    def ome_dotdot(folder, outside):
        store = _zarr(folder, True, 2)
        shutil.copytree(store / "0", outside / "level")
        attrs = json.loads((store / ".zattrs").read_text())
        attrs["multiscales"][0]["datasets"][0]["path"] = os.path.relpath(outside / "level", store)
        (store / ".zattrs").write_text(json.dumps(attrs))
        return store, ()
    add("OME dataset path with ..", ome_dotdot)

    def h5(kind):
        def build(folder, outside):
            import h5py

            snap = _particles(folder, "hdf5")
            with h5py.File(outside / "o.hdf5", "w") as f:
                f["Density"] = np.array([2.0, 1, 0.5])
            with h5py.File(snap, "a") as f:
                del f["PartType0/Density"]
                if kind == "external link":
                    f["PartType0/Density"] = h5py.ExternalLink(str(outside / "o.hdf5"), "/Density")
                elif kind == "virtual dataset":
                    layout = h5py.VirtualLayout(shape=(3,), dtype="f8")
                    layout[:] = h5py.VirtualSource(str(outside / "o.hdf5"), "Density", shape=(3,))
                    f["PartType0"].create_virtual_dataset("Density", layout)
                else:
                    raw = outside / "density.raw"
                    raw.write_bytes(np.array([2.0, 1, 0.5]).tobytes())
                    f["PartType0"].create_dataset("Density", shape=(3,), dtype="<f8",
                                                  external=[(str(raw), 0, 24)])
            return snap, ()
        return build

    for kind in ("external link", "virtual dataset", "external storage"):
        add(f"HDF5 {kind}", h5(kind))

    def nrrd(kind):
        def build(folder, outside):
            data = outside / "v.raw"
            data.write_bytes(DATA.astype("<i2").tobytes())
            if kind == "linked":
                (folder / "v.raw").symlink_to(data)
                name = "v.raw"
            else:
                name = str(data) if kind == "absolute" else os.path.relpath(data, folder)
            (folder / "v.nhdr").write_text("NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n"
                                           f"endian: little\ndata file: {name}\n")
            return folder / "v.nhdr", ()
        return build

    for kind in ("linked", "absolute", "dotdot"):
        add(f"NRRD data file {kind}", nrrd(kind))

    def dicom_member(folder, outside):
        series = _dicom(folder)
        twin = _dicom(outside)
        first = sorted(series.iterdir())[0]
        first.unlink()
        first.symlink_to(sorted(twin.iterdir())[0])
        return series, ()
    add("DICOM member linked out", dicom_member)

    def tf_file(folder, outside):
        volume = _nrrd(folder)
        (folder / "t.vp").symlink_to(_vp(outside))
        return volume, ("--transfer-function", str(folder / "t.vp"))
    add("transfer-function file linked out", tf_file)

    def mesh_file(folder, outside):
        volume = _nrrd(folder)
        (folder / "s.obj").symlink_to(_surface(outside, ".obj"))
        return volume, ("--mesh", str(folder / "s.obj"))
    add("geometry mesh linked out", mesh_file)

    def scene(kind):
        def build(folder, outside):
            volume = _nrrd(outside)
            path = str(volume) if kind == "absolute" else os.path.relpath(volume, folder)
            (folder / "s.toml").write_text(f'[volume]\npath = "{path}"\n')
            return folder / "s.toml", ()
        return build

    add("scene volume.path absolute", scene("absolute"))
    add("scene volume.path with ..", scene("dotdot"))
    return cases


MAKERS = {
    "nrrd": lambda f: _nrrd(f), "vti": _vti, "dicom": _dicom,
    "zarr v2": lambda f: _zarr(f, False, 2), "zarr v3": lambda f: _zarr(f, False, 3),
    "ome-zarr 0.4": lambda f: _zarr(f, True, 2), "ome-zarr 0.5": lambda f: _zarr(f, True, 3),
    "particles csv": lambda f: _particles(f, "csv"), "particles hdf5": lambda f: _particles(f, "hdf5"),
    "vtu": _vtu, "vtk mesh": _legacy_mesh,
    "obj": lambda f: _surface(f, ".obj"), "ply": lambda f: _surface(f, ".ply"), "stl": lambda f: _surface(f, ".stl"),
    "slicer vp": _vp, "paraview json": _paraview,
}
GEOMETRY = ("obj", "ply", "stl")
TRANSFER_FUNCTIONS = ("slicer vp", "paraview json")
TEXT_SUFFIXES = (".nhdr", ".vti", ".vtu", ".vtk", ".csv", ".obj", ".ply", ".stl", ".vp", ".json", ".zarray",
                 ".zattrs", ".zgroup")


def _mutate_one(files: list[Path], rnd: random.Random) -> str:
    target = rnd.choice(files)
    blob = target.read_bytes()
    if (target.suffix in TEXT_SUFFIXES or target.name == "zarr.json") and rnd.random() < 0.7:
        if target.suffix in (".json", ".zarray", ".zattrs", ".zgroup") or target.name == "zarr.json":
            new, what = _mutate_json(blob, rnd)
        else:
            new, what = mutate_lines(blob, rnd)
    else:
        new, what = mutate_bytes(blob, rnd)
    target.write_bytes(new)
    return f"{target.name}: {what}"


def _mutate_json(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A JSON value somewhere in the document replaced by a value of another type or range, or a key dropped."""
    try:
        doc = json.loads(blob)
    except ValueError:
        return mutate_bytes(blob, rnd)
    slots = []

    def walk(node):
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, value in items:
            slots.append((node, key))
            walk(value)
    walk(doc)
    if not slots:
        return mutate_bytes(blob, rnd)
    node, key = rnd.choice(slots)
    wild = [None, True, -1, 0, 1e300, -1e300, 2**70, "x", "..", "/etc/passwd", [], {}, [1, 2], [None],
            {"a": 1}, float("nan"), 1.5, 10**6, [10**6] * 3]
    if isinstance(node, dict) and rnd.random() < 0.25:
        del node[key]
        what = f"drop {key!r}"
    else:
        node[key] = rnd.choice(wild)
        what = f"{key!r} -> {node[key]!r}"
    return json.dumps(doc, allow_nan=True).encode(), what


def mutated_case(folder: Path, kind: str, rnd: random.Random) -> Case:
    made = MAKERS[kind](folder)
    files = [p for p in ([made] if made.is_file() else made.rglob("*")) if p.is_file()]
    what = _mutate_one(files, rnd)
    if kind in GEOMETRY:
        args = _render(folder, _nrrd(folder, "g.nhdr", "g.raw"), "--mesh", str(made))
    elif kind in TRANSFER_FUNCTIONS:
        args = _render(folder, _nrrd(folder, "g.nhdr", "g.raw"), "--transfer-function", str(made))
    else:
        args = _render(folder, made)
        if rnd.random() < 0.2:
            args = ["info", str(made), "--sandbox", str(folder)]
    return Case("mutated", f"{kind}: {what}", folder, args)


def _general() -> tuple[str, ...]:
    """The renderers a settings case draws from: every GL renderer of grids, and the same-discretization
    judge (the converged one is the slow judge of accuracy, not an input surface of its own)."""
    gl = [n for n, p in registry.plugins().items() if p.needs_gl and p.data_kinds and "grid" in p.data_kinds]
    return (*gl, DISCRETE)


def _taking(setting: str) -> tuple[str, ...]:
    """The renderers of :data:`GENERAL` that declare ``setting``."""
    return tuple(n for n in GENERAL if registry.plugin(n).declared(setting) is not None)


GENERAL = _general()
SETTINGS = {  # flag -> (absurd or extreme values, the renderers that take it)
    "--kernel-width": (["1e6", "1e-9", "0", "-1", "nan", "1e300", "50"], _taking("kernel_width")),
    "--slab-width": (["1e9", "1e-5", "0", "inf", "1e-3"], _taking("slab_width")),
    "--screen-low-pass": (["1e6", "-1", "0", "1e-9"], _taking("screen_low_pass")),
    "--padding": (["1e6", "0", "-2", "1e-9", "16"], _taking("padding")),
    "--slice-bandwidth": (["1e6", "0", "-1"], _taking("slice_bandwidth")),
    "--sample-distance-voxels": (["1e-7", "1e9", "-0", "1e-4"], GENERAL),
    "--lut-size": (["1", "0", "16385", "1000000000"], GENERAL),
    "--rescale-intercept": (["1e300", "-1e300", "nan", "1e30"], GENERAL),
    "--max-seconds": (["1e-9", "0", "-1", "nan", "inf", "1e400", "0.5"], GENERAL),
    "--max-memory": (["1", "0", "4MiB", "-5", "1e30"], GENERAL),
    "--size": (["1x1", "0x0", "20000x2000", "16384x16384", "2048x2048"], GENERAL),
    "--iso-value": (["1e300", "nan"], _taking("iso_value")),
    "--ert-threshold": (["0", "1", "2"], _taking("ert_threshold")),
    "--dask": (["ucx://127.0.0.1:1", "tls://127.0.0.1:1", "tcp://", "127.0.0.1:1", "local:0", "local:1000"],
               tuple(n for n in GENERAL if registry.plugin(n).sort_last)),
}


def _volume(folder: Path, n: int) -> Path:
    """An ``n``-cubed uint8 volume of blobs (a NRRD with its data attached)."""
    z, y, x = np.mgrid[:n, :n, :n] / max(n - 1, 1) - 0.5
    data = (255 * np.exp(-12 * (x * x + y * y + z * z))).astype(np.uint8)
    path = folder / "b.nrrd"
    path.write_bytes(f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\n\n".encode()
                     + data.tobytes())
    return path


def settings_case(folder: Path, rnd: random.Random) -> Case:
    flag = rnd.choice(sorted(SETTINGS))
    values, renderers = SETTINGS[flag]
    renderer = rnd.choice(renderers)
    volume = rnd.choice([_nrrd(folder), _volume(folder, rnd.choice([16, 64, 128]))]) \
        if "particles" not in (registry.plugin(renderer).data_kinds or ()) or rnd.random() < 0.7 \
        else _particles(folder, "csv")
    extra = ["--renderer", renderer, flag, rnd.choice(values)]
    second = rnd.choice([f for f, (_, r) in SETTINGS.items() if renderer in r and f != flag])
    if rnd.random() < 0.5:
        extra += [second, rnd.choice(SETTINGS[second][0])]
    args = _render(folder, volume, *extra)
    if "--size" in extra:  # the flag given last wins
        args = [a for i, a in enumerate(args) if not (i < 6 and a in SIZE)]
    return Case("settings", " ".join(extra), folder, args)


# --- running and judging ---------------------------------------------------------------------------

def judge(case: Case, proc: subprocess.CompletedProcess | None, seconds: float, timeout: float,
          stderr: str) -> str:
    """``"ok: ..."`` or a finding."""
    lines = [ln for ln in stderr.splitlines() if ln.strip() and not _is_progress(ln)]
    wrote = any(p.name.startswith("out") for p in case.folder.iterdir())
    if proc is None:
        return "ok: long, with progress" if any(_is_progress(ln) for ln in stderr.splitlines()) else \
            f"FINDING: ran past {timeout:g} s without a progress bar"
    if "Traceback" in stderr:
        return "FINDING: traceback"
    if proc.returncode == 0:
        if case.must_refuse:
            return "FINDING: the escape was read (exit 0)"
        return "ok: rendered" if wrote or case.args[0] == "info" else "FINDING: exit 0 without output"
    if proc.returncode == 1:
        errors = [ln for ln in lines if ": error: " in ln]
        if len(errors) != 1:
            return f"FINDING: exit 1 with {len(errors)} error lines"
        if wrote:
            return "FINDING: refused but wrote output"
        return "ok: refused"
    return f"FINDING: exit {proc.returncode}"


def _is_progress(line: str) -> bool:
    return "%|" in line or "it/s" in line or "step/s" in line or "s/step" in line or "\r" in line


def run_case(case: Case, timeout: float) -> tuple[str, float, str]:
    start = time.monotonic()
    env = dict(os.environ, PYTHONWARNINGS="default")
    try:
        proc = subprocess.run(DVR + case.args, cwd=case.folder, capture_output=True, text=True, timeout=timeout,
                              env=env)
        stderr = proc.stderr
    except subprocess.TimeoutExpired as exc:
        proc, stderr = None, (exc.stderr or b"").decode(errors="replace") if isinstance(exc.stderr, bytes) \
            else (exc.stderr or "")
    seconds = time.monotonic() - start
    return judge(case, proc, seconds, timeout, stderr), seconds, stderr


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--examples", type=int, default=300, help="mutated and settings cases (default 300)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds a silent run may take (default 60)")
    parser.add_argument("--families", default="escape,mutated,settings")
    parser.add_argument("--keep", type=Path, help="keep the case folders of findings here")
    args = parser.parse_args(argv)
    rnd = random.Random(args.seed)
    families = set(args.families.split(","))
    counts: dict[str, Counter] = defaultdict(Counter)
    findings = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        serial = iter(range(10**9))

        def make_folder(name):
            base = tmp / f"case{next(serial):05d}"
            folder, outside = base / "root", base / "outside"
            folder.mkdir(parents=True)
            outside.mkdir()
            return folder, outside

        cases = escape_cases(make_folder) if "escape" in families else []
        kinds = sorted(MAKERS)
        for i in range(args.examples):
            folder, _ = make_folder("")
            if "mutated" in families and ("settings" not in families or i % 3):
                cases.append(mutated_case(folder, kinds[i % len(kinds)], rnd))
            elif "settings" in families:
                cases.append(settings_case(folder, rnd))
        for n, case in enumerate(cases):
            verdict, seconds, stderr = run_case(case, args.timeout)
            label = case.family if case.family != "mutated" else case.name.split(":")[0]
            counts[label]["cases"] += 1
            counts[label][verdict.split(":")[0]] += 1
            counts[label]["max seconds"] = max(counts[label]["max seconds"], round(seconds, 1))
            if verdict.startswith("FINDING"):
                findings.append((case, verdict, stderr))
                if args.keep:
                    shutil.copytree(case.folder.parent, args.keep / case.folder.parent.name, symlinks=True)
            print(f"[{n + 1}/{len(cases)}] {verdict[:60]:60s} {seconds:5.1f} s  {case.family}: {case.name[:70]}",
                  file=sys.stderr)
    print("\n| surface | cases | ok | findings | slowest (s) |\n|---|---:|---:|---:|---:|")
    for label in sorted(counts):
        c = counts[label]
        print(f"| {label} | {c['cases']} | {c['ok']} | {c['FINDING']} | {c['max seconds']:g} |")
    for case, verdict, stderr in findings:
        print(f"\n{verdict}: {case.family}: {case.name}\n  dvr {' '.join(case.args)}\n  {stderr.strip()[-600:]}")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
