"""zarr arrays and OME-Zarr images written here with zarr: axes found by name, levels, the
coordinate transformations as spacing and origin, and the refusals."""

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_volume

zarr = pytest.importorskip("zarr", reason="zarr reads zarr stores (extra 'zarr')")

DATA = np.arange(4 * 3 * 2, dtype=np.uint16).reshape(2, 3, 4)  # [z, y, x]


def write_ome(path, data_zyx=DATA, axes=("z", "y", "x"), extra=(), levels=2, translation=(10.0, 20.0, 30.0)):
    """An OME-Zarr 0.4 image: ``axes`` in the stored order (``extra`` axes of size 1 or more in front), each
    level half the last along x and y; scale (z, y, x) = (2, 0.75, 0.5) at level 0."""
    group = zarr.open_group(str(path), mode="w")
    base = {"z": 2.0, "y": 0.75, "x": 0.5}
    shift = dict(zip("zyx", translation))
    datasets = []
    for level in range(levels):
        step = 2 ** level
        zyx = data_zyx[:, ::step, ::step]
        stored = np.transpose(zyx, ["zyx".index(a) for a in axes])
        stored = np.broadcast_to(stored, tuple(n for _, n in extra) + stored.shape)  # t, c in front
        group.create_array(str(level), data=np.ascontiguousarray(stored))
        scale = [1.0] * len(extra) + [base[a] * (1 if a == "z" else step) for a in axes]
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": scale},
            {"type": "translation", "translation": [0.0] * len(extra) + [shift[a] for a in axes]}]})
    kinds = {"t": "time", "c": "channel"}
    group.attrs["multiscales"] = [{"version": "0.4", "datasets": datasets, "axes":
                                   [{"name": n, "type": kinds[n]} for n, _ in extra]
                                   + [{"name": a, "type": "space", "unit": "micrometer"} for a in axes]}]
    return path


def test_plain_array_and_group_with_one_array(tmp_path):
    zarr.save_array(str(tmp_path / "a.zarr"), DATA)
    assert detect_format(tmp_path / "a.zarr") == "zarr"
    np.testing.assert_array_equal(load_volume(tmp_path / "a.zarr").data, DATA)
    group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    group.create_array("density", data=DATA)
    np.testing.assert_array_equal(load_volume(tmp_path / "g.zarr").data, DATA)
    group.create_array("labels", data=DATA + 1)
    with pytest.raises(VolumeError, match=r"holds 2 arrays \('density', 'labels'\); name one with volume.array"):
        load_volume(tmp_path / "g.zarr")
    np.testing.assert_array_equal(load_volume(tmp_path / "g.zarr", array="labels").data, DATA + 1)


def test_ome_zarr_level_0_scale_and_translation(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.ome.zarr"))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 0.75, 2.0) and v.origin == (30.0, 20.0, 10.0)


def test_ome_zarr_coarser_level(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.ome.zarr"), level=1)
    np.testing.assert_array_equal(v.data, DATA[:, ::2, ::2])
    assert v.spacing == (1.0, 1.5, 2.0)
    with pytest.raises(VolumeError, match="volume.level 2 is out of range; the image has 2 levels"):
        load_volume(tmp_path / "i.ome.zarr", level=2)


def test_axes_in_another_order_are_transposed_by_name(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.zarr", axes=("x", "y", "z")))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 0.75, 2.0) and v.origin == (30.0, 20.0, 10.0)


def test_singleton_time_and_channel_are_dropped(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.zarr", extra=(("t", 1), ("c", 1))))
    np.testing.assert_array_equal(v.data, DATA)


def test_several_channels_are_each_a_field(tmp_path):
    """Issue 42: a channel axis of 3 gives 3 scalar members on one grid (tests/io/test_io_channels.py has more)."""
    fields = load_volume(write_ome(tmp_path / "i.zarr", extra=(("c", 3),)))
    assert [m.name for m in fields.members] == ["channel 0", "channel 1", "channel 2"]
    for m in fields.members:
        np.testing.assert_array_equal(m.field.data, DATA)
        assert m.field.spacing == (0.5, 0.75, 2.0) and m.field.origin == (30.0, 20.0, 10.0)


def test_level_on_a_plain_group_is_refused(tmp_path):
    group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    group.create_array("density", data=DATA)
    with pytest.raises(VolumeError, match="volume.level applies to OME-Zarr"):
        load_volume(tmp_path / "g.zarr", level=1)


def test_not_a_volume(tmp_path):
    zarr.save_array(str(tmp_path / "a.zarr"), np.zeros((3, 4)))
    with pytest.raises(VolumeError, match=r"shape \(3, 4\); a volume needs 3 dimensions"):
        load_volume(tmp_path / "a.zarr")


# --- issue 40: the sandbox through links, the OME metadata checked, damaged stores in one line ----------

import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

from dvr_gl.sandbox import Sandbox, SandboxError, active  # noqa: E402


def store_pair(tmp_path, kind):
    """The same store in ``box`` (the sandbox's root) and ``out`` (outside it), the outside one with other
    values: ``kind`` is "v2", "v3" (a bare array) or "ome" (OME-Zarr 0.4)."""
    stores = []
    for folder, data in (("box", DATA), ("out", DATA + 1000)):
        path = tmp_path / folder / "s.zarr"
        path.parent.mkdir()
        if kind == "ome":
            write_ome(path, data, levels=1)
        else:
            zarr.create_array(str(path), shape=data.shape, dtype=data.dtype, zarr_format=int(kind[1]))[...] = data
        stores.append(path)
    return stores


@pytest.mark.parametrize("kind, member", [("v2", "0.0.0"), ("v2", ".zarray"), ("v2", ".zattrs"),
                                          ("v3", "c/0/0/0"), ("v3", "zarr.json"), ("ome", "zarr.json"),
                                          ("ome", "0/zarr.json"), ("ome", "0/c/0/0/0")])
def test_a_member_linked_out_of_the_sandbox_is_refused(tmp_path, kind, member):
    """Each member of a store linked to the same member of a store outside the sandbox's root: read
    without a sandbox (the escape the link makes), refused in one line under one, before any voxel."""
    box, out = store_pair(tmp_path, kind)
    sandbox = Sandbox(roots=(tmp_path / "box",))
    with active(sandbox):
        np.testing.assert_array_equal(load_volume(box).data, DATA)  # the store itself is fine
    (box / member).unlink()
    (box / member).symlink_to(out / member)
    if member.endswith(("0.0.0", "0/0/0")):
        np.testing.assert_array_equal(load_volume(box).data, DATA + 1000)  # without a sandbox: the link's values
    with active(sandbox), pytest.raises(SandboxError, match=rf"s.zarr/{member}: the zarr store's file lies outside "
                                                            r"the allowed folders .* once links are followed"):
        load_volume(box)


def test_a_folder_linked_out_of_the_sandbox_is_refused(tmp_path):
    box, out = store_pair(tmp_path, "ome")
    import shutil

    shutil.rmtree(box / "0")
    (box / "0").symlink_to(out / "0", target_is_directory=True)
    with active(Sandbox(roots=(tmp_path / "box",))), pytest.raises(SandboxError, match="once links are followed"):
        load_volume(box)


def test_a_chunk_that_is_a_fifo_is_refused_not_waited_on(tmp_path):
    path = tmp_path / "a.zarr"
    zarr.create_array(str(path), shape=DATA.shape, dtype=DATA.dtype, zarr_format=2)[...] = DATA
    (path / "0.0.0").unlink()
    os.mkfifo(path / "0.0.0")
    with pytest.raises(SandboxError, match="0.0.0: the zarr store's file is not a regular file"):
        load_volume(path)


def test_a_chunk_that_is_a_folder_is_refused_not_read_as_missing(tmp_path):
    """zarr reads a folder at a chunk's key as a missing chunk (its fill value: a hole in the picture)."""
    path = tmp_path / "a.zarr"
    zarr.create_array(str(path), shape=DATA.shape, chunks=(1, 3, 4), dtype=DATA.dtype, zarr_format=2)[...] = DATA
    (path / "1.0.0").unlink()
    (path / "1.0.0").mkdir()
    with pytest.raises(VolumeError, match="1.0.0: a folder where the store has a file"):
        load_volume(path)


def edit_json(path, change):
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def edit_attrs(store, change):
    """Change a group's attributes where zarr keeps them (v2: .zattrs; v3: zarr.json's 'attributes')."""
    if (store / ".zattrs").is_file():
        edit_json(store / ".zattrs", change)
    else:
        edit_json(store / "zarr.json", lambda j: change(j["attributes"]))


def ms(attrs):
    return attrs["multiscales"][0]


def scale(attrs):
    return ms(attrs)["datasets"][0]["coordinateTransformations"][0]


# (what the test changes in the OME-Zarr 0.4 attributes, a fragment of the one-line message)
OME_CASES = {
    "multiscales an object": (lambda a: a.update(multiscales=ms(a)), "'multiscales' is an object; OME-Zarr wants a "
                                                                     "list"),
    "multiscales empty": (lambda a: a.update(multiscales=[]), "'multiscales' is an empty list"),
    "no datasets": (lambda a: ms(a).pop("datasets"), "the multiscales 'datasets' is missing"),
    "datasets an object": (lambda a: ms(a).update(datasets={"path": "0"}), "'datasets' is an object"),
    "no path": (lambda a: ms(a)["datasets"][0].pop("path"), "dataset 0 \\(an object\\) has no 'path'"),
    "path a number": (lambda a: ms(a)["datasets"][0].update(path=0), "dataset 0 has path 0; a path is the array's "
                                                                      "name"),
    "path with ..": (lambda a: ms(a)["datasets"][0].update(path="../out/s.zarr/0"), "has path '../out/s.zarr/0', "
                                                                                    "which leaves the image"),
    "absolute path": (lambda a: ms(a)["datasets"][0].update(path="/etc"), "has path '/etc', which leaves the image"),
    "path of no array": (lambda a: ms(a)["datasets"][0].update(path="7"), "dataset path '7' names no array"),
    "axes not a list": (lambda a: ms(a).update(axes="zyx"), "the multiscales 'axes' is 'zyx'"),
    "no axes": (lambda a: ms(a).pop("axes"), "the multiscales 'axes' is missing"),
    "axis without a name": (lambda a: ms(a)["axes"][0].pop("name"), "axis 0 has name missing"),
    "axis name a number": (lambda a: ms(a)["axes"][0].update(name=3), "axis 0 has name 3"),
    "axes repeated": (lambda a: ms(a)["axes"][1].update(name="z"), "repeat a name"),
    "axes a, b, c": (lambda a: [ax.update(name=n) for ax, n in zip(ms(a)["axes"], "abc")],
                     "the axes are named a, b, c; a volume needs axes named z, y and x"),
    "scale too short": (lambda a: scale(a).update(scale=[1, 2]), "dataset 0's scale is \\[1, 2\\]; it needs 3 finite "
                                                                 "numbers"),
    "scale a string": (lambda a: scale(a).update(scale="1 2 3"), "dataset 0's scale is '1 2 3'"),
    "scale of strings": (lambda a: scale(a).update(scale=["a", "b", "c"]), "dataset 0's scale is \\[\"a\""),
    "scale NaN": (lambda a: scale(a).update(scale=[float("nan"), 1, 1]), "dataset 0's scale is \\[NaN"),
    "scale zero": (lambda a: scale(a).update(scale=[0, 1, 1]), "the scale coordinateTransformation must be three "
                                                               "finite numbers > 0"),
    "scale negative": (lambda a: scale(a).update(scale=[1, -1, 1]), "must be three finite numbers > 0"),
    "scale missing": (lambda a: scale(a).pop("scale"), "dataset 0's scale is missing"),
    "translation too short": (lambda a: ms(a)["datasets"][0]["coordinateTransformations"][1].update(translation=[1]),
                              "dataset 0's translation is \\[1\\]"),
    "transforms an object": (lambda a: ms(a)["datasets"][0].update(coordinateTransformations={"type": "scale"}),
                             "coordinateTransformations is an object, not a list"),
    "transform a string": (lambda a: ms(a)["datasets"][0].update(coordinateTransformations=["scale"]),
                           "coordinateTransformations hold 'scale', not an object"),
    "unknown transform": (lambda a: scale(a).update(type="rotation"), "a coordinateTransformation of type "
                                                                      "'rotation'; OME-Zarr images have 'scale'"),
    "scale in a file": (lambda a: scale(a).update(scale=None, path="scale.bin"), "scale is stored in a file"),
    "unknown version": (lambda a: ms(a).update(version="9.9"), "OME-Zarr version '9.9' is not one this reader knows"),
}


@pytest.mark.parametrize("case", list(OME_CASES))
def test_ome_metadata_checked_before_any_array_is_opened(tmp_path, case):
    change, message = OME_CASES[case]
    path = write_ome(tmp_path / "i.zarr", levels=1)
    edit_attrs(path, change)
    with pytest.raises(VolumeError, match=message):
        load_volume(path)


def test_ome_zarr_0_5_metadata_checked_as_well(tmp_path):
    """OME-Zarr 0.5 (zarr v3, the metadata under 'ome'): read, and the same checks."""
    group = zarr.open_group(str(tmp_path / "i.zarr"), mode="w", zarr_format=3)
    group.create_array("0", data=DATA)
    group.attrs["ome"] = {"version": "0.5", "multiscales": [{"axes": [{"name": a, "type": "space"} for a in "zyx"],
                          "datasets": [{"path": "0", "coordinateTransformations": [
                              {"type": "scale", "scale": [2.0, 0.75, 0.5]}]}]}]}
    v = load_volume(tmp_path / "i.zarr")
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 0.75, 2.0)
    edit_json(tmp_path / "i.zarr" / "zarr.json", lambda j: j["attributes"]["ome"].update(multiscales={}))
    with pytest.raises(VolumeError, match="'multiscales' is an empty object; OME-Zarr wants a list"):
        load_volume(tmp_path / "i.zarr")
    edit_json(tmp_path / "i.zarr" / "zarr.json", lambda j: j["attributes"].update(ome="0.5"))
    with pytest.raises(VolumeError, match="the 'ome' attribute is '0.5', not an object"):
        load_volume(tmp_path / "i.zarr")


def array_meta(path):
    return next(p for p in (path / ".zarray", path / "zarr.json") if p.is_file())


@pytest.mark.parametrize("fmt", [2, 3])
@pytest.mark.parametrize("case, change, message", [
    ("complex", lambda m: m.update({"dtype": "<c8"} if "dtype" in m else {"data_type": "complex64"}),
     "metadata is not valid"),
    ("object", lambda m: m.update({"dtype": "|O"} if "dtype" in m else {"data_type": "object"}),
     "metadata is not valid"),
    ("structured", lambda m: m.update({"dtype": [["a", "<u2"]]} if "dtype" in m else {"data_type": [["a", "<u2"]]}),
     "metadata is not valid"),
    ("negative shape", lambda m: m.update(shape=[-2, 3, 4]), "non-negative"),
    ("zero chunks", lambda m: m.update(chunks=[0, 3, 4]) if "chunks" in m else
     m["chunk_grid"]["configuration"].update(chunk_shape=[0, 3, 4]), r"in chunks \[0, 3, 4\]; chunks need one"),
    ("broken JSON", None, "its metadata is not valid \\(JSONDecodeError"),
    ("chunks too small", lambda m: m.update(chunks=[1, 1, 1]) if "chunks" in m else
     m["chunk_grid"]["configuration"].update(chunk_shape=[1, 1, 1]), "a chunk of the zarr array cannot be read"),
])
def test_array_metadata_zarr_refuses_is_one_line(tmp_path, fmt, case, change, message):
    path = tmp_path / "a.zarr"
    zarr.create_array(str(path), shape=DATA.shape, dtype=DATA.dtype, zarr_format=fmt)[...] = DATA
    meta = array_meta(path)
    if change is None:
        meta.write_text(meta.read_text() + "{{{")
    else:
        edit_json(meta, change)
    with pytest.raises(VolumeError, match=message):
        load_volume(path)


def test_a_shape_of_a_million_cubed_is_refused_before_allocating(tmp_path):
    """10^6-cubed: the whole array over the memory budget (with the estimate) when read whole; out of core,
    the chunks' count; and chunks as large as the memory budget."""
    from dvr_gl.out_of_core import open_volume

    path = tmp_path / "a.zarr"
    zarr.create_array(str(path), shape=DATA.shape, dtype=DATA.dtype, zarr_format=2)[...] = DATA
    edit_json(path / ".zarray", lambda m: m.update(shape=[10 ** 6] * 3))
    with pytest.raises(SandboxError, match=r"of shape \(1000000, 1000000, 1000000\) would take 1.86e\+09 GiB, over "
                                           r"the memory budget"):
        load_volume(path)
    with pytest.raises(VolumeError, match=r"has 4.17e\+16 chunks of \[2, 3, 4\], over 16777216 \(about .* hours"):
        open_volume(path, out_of_core=True)
    edit_json(path / ".zarray", lambda m: m.update(chunks=[10 ** 5] * 3))
    with active(Sandbox(max_bytes=64 << 20)), pytest.raises(SandboxError, match=r"one chunk of \[100000, 100000, "
                                                                                  r"100000\] would take"):
        open_volume(path, out_of_core=True)


def test_volume_array_outside_the_group_is_refused(tmp_path):
    group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    group.create_array("density", data=DATA)
    with pytest.raises(VolumeError, match="volume.array has path '../g.zarr/density', which leaves"):
        load_volume(tmp_path / "g.zarr", array="../g.zarr/density")


def damaged_store(tmp_path, fmt):
    """64^3 in 8^3 chunks, one of them garbage: zarr reads the other 511 concurrently when it fails."""
    path = tmp_path / f"d{fmt}.zarr"
    data = np.arange(64 ** 3, dtype=np.uint32).reshape(64, 64, 64).astype(np.uint8)
    zarr.create_array(str(path), shape=data.shape, dtype=data.dtype, chunks=(8, 8, 8), zarr_format=fmt)[...] = data
    (path / ("3.3.3" if fmt == 2 else "c/3/3/3")).write_bytes(b"garbage\n")
    return path


@pytest.mark.parametrize("fmt", [2, 3])
def test_a_corrupt_chunk_is_one_line(tmp_path, fmt):
    from dvr_gl.out_of_core import open_volume

    path = damaged_store(tmp_path, fmt)
    with pytest.raises(VolumeError, match="a chunk of the zarr array cannot be read .*; the store is damaged"):
        load_volume(path)
    with pytest.raises(VolumeError, match="a chunk of the zarr array cannot be read"):  # the block ranges' pass
        open_volume(path, out_of_core=True, sidecar=False)


def test_a_corrupt_chunk_prints_nothing_else(tmp_path):
    """In a fresh process (the noise came at exit: "Task was destroyed but it is pending!" for each of the
    chunk reads still under way), rendering the damaged store prints one line and exits 1."""
    path = damaged_store(tmp_path, 3)
    run = subprocess.run([sys.executable, "-m", "dvr_gl.apps.cli", "render", str(path), "-o",
                          str(tmp_path / "x.png"), "--size", "32x32"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, run.stderr
    assert run.stderr.count("\n") == 1 and "a chunk of the zarr array cannot be read" in run.stderr, run.stderr
    assert not (tmp_path / "x.png").exists()


def test_files_larger_than_the_memory_budget_are_not_read(tmp_path):
    """A chunk file or metadata (parsed: 16 times its size) over the memory budget is refused before it is
    read whole; as many levels as a forged image lists are bounded too (each would be opened)."""
    path = tmp_path / "a.zarr"
    zarr.create_array(str(path), shape=DATA.shape, dtype=DATA.dtype, zarr_format=2)[...] = DATA
    with open(path / "0.0.0", "ab") as f:
        f.truncate(2 << 20)
    with active(Sandbox(max_bytes=1 << 20)), pytest.raises(SandboxError, match=r"0.0.0: reading this chunk file of "
                                                                                r"2097152 bytes would take 2 MiB"):
        load_volume(path)
    (path / ".zattrs").write_text(json.dumps({"pad": "x" * (100 << 10)}))
    with active(Sandbox(max_bytes=1 << 20)), pytest.raises(SandboxError, match=r".zattrs: reading this metadata file "
                                                                                r"of \d+ bytes would take 1.56 MiB"):
        load_volume(path)
    image = write_ome(tmp_path / "i.zarr", levels=1)
    edit_attrs(image, lambda a: ms(a).update(datasets=ms(a)["datasets"] * 100000))
    with pytest.raises(VolumeError, match="the image has 100000 levels, over 64"):
        load_volume(image)
