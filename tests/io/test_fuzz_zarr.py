"""Property-based fuzzing of the zarr reader (issue 40): small valid stores (zarr v2 and v3 arrays,
OME-Zarr 0.4 and 0.5 images) whose metadata JSON has a value replaced by a bad token (a wrong type or
range: strings for numbers, negative or huge shapes, zero chunks, paths with ``..``, complex and object
dtypes, NaN), a key dropped or its text mangled, and whose chunks are cut, corrupted or removed.

Each is read whole (``load_volume``) and out of core (``open_volume``, every voxel read), under a
sandbox whose only root is the store's folder: a user error (DvrError, one line) or a valid volume,
printing nothing (on the file descriptors too), within the time and memory budget of ``fuzz_inputs``,
with no zarr read left running on zarr's event loop (those printed "Task was destroyed but it is
pending!" at exit), and never a value of the store beside the root (its samples are marked).
Derandomized; a few seconds in all.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import math
import random
import shutil
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
zarr = pytest.importorskip("zarr", reason="zarr reads zarr stores (extra 'zarr')")
# the imports below come after importorskip on purpose: hypothesis and zarr are optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import dvr_gl.io.zarr as zarr_reader  # noqa: E402
from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.io import load_volume  # noqa: E402
from dvr_gl.out_of_core import open_volume  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from fuzz_inputs import BUDGET, TIMEOUT, mutate_bytes, time_limit  # noqa: E402

DATA = (np.arange(4 * 3 * 2, dtype=np.int16).reshape(2, 3, 4) * 37 - 300)  # [z, y, x]
MARK = 4242  # every sample of the store outside the root: a volume holding it read outside
METADATA = (".zarray", ".zattrs", ".zgroup", "zarr.json")
# JSON values of the wrong type or range, as a careless or hostile writer would put them
BAD_VALUES = [None, True, 0, -1, 1, 2, 3.5, -0.0, 1e308, -1e308, float("nan"), float("inf"), 10 ** 6, 2 ** 63,
              "", "banana", "0", "../outside/s.zarr", "/etc", "..", ".", "0/../..", "complex64", "<c8", "|O",
              "object", "float128", "<u2", "|b1", "zstd", "C", "F", [], {}, [1, 2], [0, 0, 0], [-1, -1, -1],
              [10 ** 6] * 3, [1, 1, 1], ["a", "b", "c"], [float("nan")] * 3, [[1, 2, 3]], [["a", "<u2"]],
              {"name": "z"}, {"type": "scale", "scale": [1, 1, 1]}, {"type": "translation"}, "0.4", "9.9"]
#: The most chunks a store may have while fuzzing (the reader's MAX_CHUNKS lowered, as the memory budget is):
#: a mutated shape of 10^6 in chunks of 12 samples is refused, not read for a minute.
FUZZ_CHUNKS = 256
FUZZ = settings(max_examples=20, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def write_store(path: Path, kind: str, data=DATA):
    """A store of ``kind``: "v2" or "v3" (a bare array in chunks of one plane), "ome-0.4" (zarr v2) or
    "ome-0.5" (zarr v3): two levels, axes z, y, x, a scale and a translation; "ome-tc" (issue 42, zarr v2): t and
    c axes of 2 each in front (step t, channel c holding DATA + 10 (2 t + c)), omero channel labels."""
    if kind in ("v2", "v3"):
        zarr.create_array(str(path), shape=data.shape, chunks=(1, 3, 4), dtype=data.dtype,
                          zarr_format=int(kind[1]))[...] = data
        return
    fmt = 3 if kind == "ome-0.5" else 2
    group = zarr.open_group(str(path), mode="w", zarr_format=fmt)
    datasets = []
    tc = (2, 2) if kind == "ome-tc" else ()
    for level in range(2):
        level_data = np.ascontiguousarray(data[:, ::2 ** level, ::2 ** level])
        if tc:
            level_data = level_data + 10 * np.arange(4, dtype=data.dtype).reshape(2, 2, 1, 1, 1)
        group.create_array(str(level), shape=level_data.shape, chunks=(1,) * len(tc) + (1, 2, 2),
                           dtype=data.dtype)[...] = level_data
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": [60.0, 1.0][:len(tc)] + [2.0, 0.75 * 2 ** level, 0.5 * 2 ** level]},
            {"type": "translation", "translation": [0.0] * len(tc) + [1.0, 2.0, 3.0]}]})
    axes = [{"name": "t", "type": "time", "unit": "second"}, {"name": "c", "type": "channel"}][:len(tc)]
    image = {"axes": axes + [{"name": a, "type": "space", "unit": "micrometer"} for a in "zyx"], "datasets": datasets}
    if tc:
        group.attrs["omero"] = {"channels": [{"label": "DNA"}, {"label": "tubulin"}]}
    if fmt == 2:
        group.attrs["multiscales"] = [{"version": "0.4", **image}]
    else:
        group.attrs["ome"] = {"version": "0.5", "multiscales": [image]}


KINDS = ["v2", "v3", "ome-0.4", "ome-0.5", "ome-tc"]
#: How a kind is read (load_volume's and open_volume's keywords): the image of channels and steps at step 1,
#: every channel whole, channel 1 out of core.
READS = {"ome-tc": ({"time": 1}, {"time": 1, "channel": 1})}


@pytest.fixture(scope="module")
def templates(tmp_path_factory):
    """Each kind's files, by path in the store (read once), and the marked store outside the roots."""
    base = tmp_path_factory.mktemp("zarr-seeds")
    found = {}
    for kind in KINDS:
        write_store(base / kind, kind)
        found[kind] = {str(f.relative_to(base / kind)): f.read_bytes() for f in sorted((base / kind).rglob("*"))
                       if f.is_file()}
    return found


def write_case(folder: Path, files: dict[str, bytes]) -> Path:
    """The store ``folder/box/s.zarr`` holding ``files``, beside ``folder/outside/s.zarr`` (all samples
    :data:`MARK`, the same layout) outside the sandbox's root ``folder/box``."""
    for sub in ("box", "outside"):
        shutil.rmtree(folder / sub, ignore_errors=True)
    store = folder / "box" / "s.zarr"
    for name, blob in files.items():
        (store / name).parent.mkdir(parents=True, exist_ok=True)
        (store / name).write_bytes(blob)
    zarr.create_array(str(folder / "outside" / "s.zarr"), shape=DATA.shape, dtype=DATA.dtype,
                      zarr_format=2)[...] = np.full(DATA.shape, MARK, DATA.dtype)
    return store


# --- mutations ------------------------------------------------------------------------------------

def _places(node, trail=()):
    """Every (container, key) in a JSON document, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield node, key
        yield from _places(value, trail + (key,))


def mutate_json(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A value replaced by a bad one, a key dropped, a value duplicated elsewhere, or the text mangled."""
    try:
        doc = json.loads(blob)
    except ValueError:
        return mutate_bytes(blob, rnd)
    places = list(_places(doc))
    kind = rnd.choice(["value", "value", "value", "drop", "text"]) if places else "text"
    if kind == "text":
        return mutate_bytes(blob, rnd)
    container, key = rnd.choice(places)
    if kind == "drop":
        del container[key]
        return json.dumps(doc).encode(), f"drop {key!r}"
    value = rnd.choice(BAD_VALUES)
    container[key] = value
    return json.dumps(doc).encode(), f"{key!r} -> {value!r}"


def mutate_store(files: dict[str, bytes], rnd: random.Random) -> tuple[dict[str, bytes], str]:
    files = dict(files)
    name = rnd.choice(sorted(files))
    if Path(name).name in METADATA and rnd.random() < 0.85:
        files[name], what = mutate_json(files[name], rnd)
    elif rnd.random() < 0.15:
        del files[name]
        what = "removed"
    else:
        files[name], what = mutate_bytes(files[name], rnd)
    return files, f"{name}: {what}"


# --- the property ---------------------------------------------------------------------------------

@pytest.fixture(autouse=True)
def few_chunks(monkeypatch):
    monkeypatch.setattr(zarr_reader, "MAX_CHUNKS", FUZZ_CHUNKS)


def _pending() -> list:
    """The tasks still on zarr's event loop (none once a read has ended, however it ended)."""
    from zarr.core import sync

    loop = sync.loop[0]
    return [] if loop is None or loop.is_closed() else [t for t in asyncio.all_tasks(loop) if not t.done()]


def check_store(path: Path, capfd, whole: bool, kind: str = "") -> str:
    """``user error`` or ``volume`` for the store read whole (``load_volume``) or out of core (every voxel
    read); any other exception (or a hang) propagates."""
    printed = io.StringIO()
    roots = (path.parent,)
    try:
        with active(Sandbox(roots=roots, max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            if whole:
                volume = load_volume(path, **READS.get(kind, ({}, {}))[0])
                for member in getattr(volume, "members", ())[1:]:  # the channels: each checked as the first is
                    _check_volume(member.field, member.field.data)
                volume = volume.members[0].field if volume.kind == "fields" else volume
                data = volume.data
            else:
                volume = open_volume(path, out_of_core=True, sidecar=False, **READS.get(kind, ({}, {}))[1])
                data = volume.read((0, 0, 0), volume.dims)
                for level in volume.levels:
                    level.read((0, 0, 0), level.dims)
    except DvrError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return "user error"
    finally:
        out, err = capfd.readouterr()
        assert not printed.getvalue() and not out and not err, (printed.getvalue() + out + err)[:300]
        assert not _pending(), "zarr reads left running"
    _check_volume(volume, data)
    return "volume"


def _check_volume(volume, data) -> None:
    assert data.ndim == 3 and data.size > 0 and data.shape == tuple(reversed(volume.dims))
    assert data.dtype.kind != "f" or np.isfinite(data).all()
    assert not (data == MARK).any(), "a sample of the store outside the sandbox's root"
    assert len(volume.spacing) == 3 and all(math.isfinite(s) and s > 0 for s in volume.spacing)
    assert all(math.isfinite(o) for o in volume.origin)


@pytest.mark.parametrize("kind", KINDS)
def test_seed_is_a_valid_volume(tmp_path, capfd, templates, kind):
    """The unmutated stores load, whole and out of core (the mutations start from something that works)."""
    for whole in (True, False):
        assert check_store(write_case(tmp_path, templates[kind]), capfd, whole, kind) == "volume"
    read = load_volume(write_case(tmp_path, templates[kind]), **READS.get(kind, ({}, {}))[0])
    for c, member in enumerate(getattr(read, "members", ())):  # step 1's channels
        np.testing.assert_array_equal(member.field.data, DATA + 10 * (2 + c))
        assert member.name == ["DNA", "tubulin"][c]
    if read.kind != "fields":
        np.testing.assert_array_equal(read.data, DATA)


@pytest.mark.parametrize("kind", KINDS)
@FUZZ
@given(rnd=st.randoms(use_true_random=False), whole=st.booleans())
def test_mutated_store_is_a_user_error_or_a_volume(tmp_path, capfd, templates, kind, rnd, whole):
    files, _ = mutate_store(templates[kind], rnd)
    check_store(write_case(tmp_path, files), capfd, whole, kind)


@pytest.mark.parametrize("kind", KINDS)
@settings(FUZZ, max_examples=8)
@given(rnd=st.randoms(use_true_random=False))
def test_members_linked_out_of_the_root_are_never_read(tmp_path, capfd, templates, kind, rnd):
    """Some of the store's files replaced by links to the marked store beside the root (the same names
    where they exist there, else its first chunk): a user error, never a marked sample."""
    store = write_case(tmp_path, templates[kind])
    outside = tmp_path / "outside" / "s.zarr"
    names = sorted(templates[kind])
    for name in rnd.sample(names, rnd.randint(1, min(3, len(names)))):
        target = outside / (Path(name).name if (outside / Path(name).name).is_file() else "0.0.0")
        (store / name).unlink()
        (store / name).symlink_to(target)
    check_store(store, capfd, rnd.random() < 0.5, kind)
