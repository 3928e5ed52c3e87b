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


# --- blosc chunks whose header lies: c-blosc read past them (a segfault, heap memory as samples) --------

import struct  # noqa: E402

numcodecs = pytest.importorskip("numcodecs")
from zarr.codecs import BloscCodec, Crc32cCodec, TransposeCodec  # noqa: E402

BLOSC_DATA = np.arange(2 * 6 * 8, dtype=np.int16).reshape(2, 6, 8) % 7  # [z, y, x], compressible


def blosc_store(path, fmt, cname="lz4", shuffle=1, data=BLOSC_DATA, **options):
    """``data`` in blosc chunks of one plane, zarr ``fmt`` 2 (compressor 'blosc') or 3 (codec 'blosc')."""
    compressor = numcodecs.Blosc(cname=cname, shuffle=shuffle) if fmt == 2 else \
        BloscCodec(cname=cname, shuffle=["noshuffle", "shuffle", "bitshuffle"][shuffle])
    options.setdefault("compressors", compressor)
    zarr.create_array(str(path), shape=data.shape, chunks=(1,) + data.shape[1:], dtype=data.dtype, zarr_format=fmt,
                      **options)[...] = data
    return path


def chunk_of(path, fmt):
    return path / ("0.0.0" if fmt == 2 else "c/0/0/0")


def _header(chunk, **fields):
    """The chunk with header fields replaced: ``typesize`` (byte 3), ``nbytes``, ``blocksize``, ``cbytes``."""
    b = bytearray(chunk)
    if "typesize" in fields:
        b[3] = fields["typesize"]
    for name, at in (("nbytes", 4), ("blocksize", 8), ("cbytes", 12)):
        if name in fields:
            struct.pack_into("<I", b, at, fields[name])
    return bytes(b)


#: damage, and what the refusal says of it
BLOSC_DAMAGE = {
    "sizes ~2 GB (bytes 7, 15)": (lambda b: b[:7] + b"\x7f" + b[8:15] + b"\x7f" + b[16:],
                                  r"header gives 2130706\d+ compressed bytes, the chunk holds"),
    "cut to 20 bytes": (lambda b: b[:20], r"header gives \d+ compressed bytes, the chunk holds 20\)"),
    "cut inside the header": (lambda b: b[:10], r"10 bytes, shorter than blosc's 16-byte header"),
    "nbytes 2 GB": (lambda b: _header(b, nbytes=2 << 30), r"gives 2147483648 bytes uncompressed, the array's "
                                                          r"chunk holds 96"),
    "nbytes short": (lambda b: _header(b, nbytes=8), r"gives 8 bytes uncompressed, the array's chunk holds 96"),
    "blocksize 0": (lambda b: _header(b, blocksize=0), r"gives blocks of 0 bytes for 96 bytes"),
    "blocksize over nbytes": (lambda b: _header(b, blocksize=1 << 20), r"blocks of 1048576 bytes for 96"),
    "typesize 0": (lambda b: _header(b, typesize=0), r"gives a type size of 0"),
}


@pytest.mark.parametrize("fmt", [2, 3])
@pytest.mark.parametrize("damage", list(BLOSC_DAMAGE))
def test_a_blosc_chunk_whose_header_lies_is_refused_in_one_line(tmp_path, fmt, damage):
    """Each damaged header, read whole and out of core: one line naming the store and the chunk, before
    numcodecs decodes it (it segfaulted, or decoded heap memory: values changing from read to read)."""
    from dvr_gl.out_of_core import open_volume

    path = blosc_store(tmp_path / "b.zarr", fmt)
    chunk = chunk_of(path, fmt)
    change, says = BLOSC_DAMAGE[damage]
    chunk.write_bytes(change(chunk.read_bytes()))
    key = "0.0.0" if fmt == 2 else "c/0/0/0"
    message = rf"b.zarr: chunk '{key}': the blosc chunk is damaged \(.*{says}.*; rewrite the store"
    with pytest.raises(VolumeError, match=message) as err:
        load_volume(path)
    assert "\n" not in str(err.value)
    with pytest.raises(VolumeError, match=message):
        open_volume(path, out_of_core=True, sidecar=False)


def test_a_memcpyed_blosc_chunk_of_the_wrong_length_is_refused(tmp_path):
    """A chunk stored uncompressed (flag 0x2: random samples) holds nbytes after its header, no more, no less."""
    data = np.random.default_rng(1).integers(-30000, 30000, (2, 6, 8)).astype(np.int16)
    path = blosc_store(tmp_path / "m.zarr", 2, cname="blosclz", shuffle=0, data=data)
    chunk = chunk_of(path, 2).read_bytes()
    assert chunk[2] & 0x2 and len(chunk) == 16 + 96  # stored uncompressed
    np.testing.assert_array_equal(load_volume(path).data, data)
    chunk_of(path, 2).write_bytes(_header(chunk + bytes(8), cbytes=len(chunk) + 8))
    with pytest.raises(VolumeError, match=r"it is stored uncompressed, 104 bytes for 96"):
        load_volume(path)


@pytest.mark.parametrize("fmt", [2, 3])
@pytest.mark.parametrize("damage", ["sizes ~2 GB (bytes 7, 15)", "cut to 20 bytes"])
def test_a_damaged_blosc_chunk_through_the_cli(tmp_path, fmt, damage):
    """In a fresh process, under a sandbox (``dvr render`` and ``dvr info`` exited 139, a segfault, or rendered
    heap memory): one line, exit 1, no image."""
    path = blosc_store(tmp_path / "b.zarr", fmt)
    chunk = chunk_of(path, fmt)
    chunk.write_bytes(BLOSC_DAMAGE[damage][0](chunk.read_bytes()))
    for command in (["render", "--sandbox", str(tmp_path), str(path), "-o", str(tmp_path / "x.png"), "--size",
                     "32x32"], ["info", str(path)]):
        run = subprocess.run([sys.executable, "-m", "dvr_gl.apps.cli", *command], capture_output=True, text=True,
                             timeout=300)
        assert run.returncode == 1, (command[0], run.returncode, run.stderr)
        assert run.stderr.count("\n") == 1 and "the blosc chunk is damaged" in run.stderr, run.stderr
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("fmt", [2, 3])
@pytest.mark.parametrize("cname, shuffle", [("lz4", 1), ("zstd", 2), ("blosclz", 0), ("zlib", 1), ("lz4hc", 2)])
def test_valid_blosc_chunks_still_read(tmp_path, fmt, cname, shuffle):
    """Chunks zarr writes with blosc, compressible and not (stored uncompressed), of 1 to 8 bytes a sample,
    read whole and out of core as written: the header check refuses none."""
    from dvr_gl.out_of_core import open_volume

    rng = np.random.default_rng(0)
    for k, data in enumerate([BLOSC_DATA, rng.integers(0, 255, (3, 5, 7)).astype(np.uint8),
                              rng.random((3, 5, 7)).astype(np.float32), rng.random((2, 5, 7))]):
        path = blosc_store(tmp_path / f"v{k}.zarr", fmt, cname, shuffle, data=data)
        read = load_volume(path).data
        np.testing.assert_array_equal(read, data.astype(read.dtype))
        v = open_volume(path, out_of_core=True, sidecar=False)
        np.testing.assert_array_equal(v.read((0, 0, 0), v.dims), data.astype(read.dtype))


@pytest.mark.parametrize("case", ["v2 filters", "v3 crc32c", "v3 transpose", "v3 numcodecs.blosc", "v2 group",
                                  "v3 group"])
def test_valid_blosc_chunks_behind_other_codecs_still_read(tmp_path, case):
    """A filter that changes the size (delta to int32), a checksum after the frame, a transpose, numcodecs'
    own v3 codec, an array in a consolidated group: each found and checked, none refused."""
    import numcodecs.zarr3

    fmt = int(case[1])
    options = {"v2 filters": {"filters": [numcodecs.Delta(dtype="<i2", astype="<i4")]},
               "v3 crc32c": {"compressors": [BloscCodec(cname="zstd"), Crc32cCodec()]},
               "v3 transpose": {"filters": [TransposeCodec(order=(2, 1, 0))]},
               "v3 numcodecs.blosc": {"compressors": numcodecs.zarr3.Blosc(cname="lz4")}}.get(case, {})
    if "group" in case:
        group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w", zarr_format=fmt)
        compressor = numcodecs.Blosc() if fmt == 2 else BloscCodec()
        group.create_array("a", shape=BLOSC_DATA.shape, chunks=(1, 6, 8), dtype=BLOSC_DATA.dtype,
                           compressors=compressor)[...] = BLOSC_DATA
        zarr.consolidate_metadata(str(tmp_path / "g.zarr"))
        path = tmp_path / "g.zarr"
    else:
        path = blosc_store(tmp_path / "c.zarr", fmt, **options)
    np.testing.assert_array_equal(load_volume(path).data, BLOSC_DATA)


def test_blosc_is_checked_as_the_consolidated_metadata_says(tmp_path):
    """zarr reads an array's metadata from the group's consolidated metadata: the check follows it, so a
    .zarray that says zlib does not hide a damaged blosc chunk (this segfaulted)."""
    path = tmp_path / "g.zarr"
    group = zarr.open_group(str(path), mode="w", zarr_format=2)
    group.create_array("a", shape=BLOSC_DATA.shape, chunks=(1, 6, 8), dtype=BLOSC_DATA.dtype,
                       compressors=numcodecs.Blosc())[...] = BLOSC_DATA
    zarr.consolidate_metadata(str(path))
    own = json.loads((path / "a/.zarray").read_text())
    (path / "a/.zarray").write_text(json.dumps({**own, "compressor": {"id": "zlib", "level": 1}}))
    np.testing.assert_array_equal(load_volume(path).data, BLOSC_DATA)
    chunk = path / "a/0.0.0"
    chunk.write_bytes(BLOSC_DAMAGE["sizes ~2 GB (bytes 7, 15)"][0](chunk.read_bytes()))
    with pytest.raises(VolumeError, match=r"g.zarr: chunk 'a/0.0.0': the blosc chunk is damaged"):
        load_volume(path)


def sharded_blosc(path, index_location):
    """BLOSC_DATA in one shard of two inner blosc chunks (a plane each), its index at ``index_location``."""
    from zarr.codecs import BytesCodec, ShardingCodec

    sharding = ShardingCodec(chunk_shape=(1, 6, 8), codecs=[BytesCodec(), BloscCodec(cname="zstd")],
                             index_location=index_location)
    zarr.create_array(str(path), shape=BLOSC_DATA.shape, chunks=BLOSC_DATA.shape, dtype=BLOSC_DATA.dtype,
                      zarr_format=3, serializer=sharding, compressors=None)[...] = BLOSC_DATA
    return path


@pytest.mark.parametrize("index_location", ["end", "start"])
def test_blosc_chunks_inside_a_shard_are_checked(tmp_path, index_location):
    """Each inner chunk of a shard: read whole (the shard's index locates each) and alone (out of core, a
    plane: zarr reads that chunk's byte range); valid ones read, a damaged one refused in one line."""
    from dvr_gl.io.zarr import open_zarr
    from dvr_gl.out_of_core import ZarrSource

    path = sharded_blosc(tmp_path / "s.zarr", index_location)
    np.testing.assert_array_equal(load_volume(path).data, BLOSC_DATA)
    np.testing.assert_array_equal(ZarrSource(open_zarr(path)[0], store=path).read((0, 0, 1), (8, 6, 1)),
                                  BLOSC_DATA[1:2])  # [z, y, x]
    shard = bytearray((path / "c/0/0/0").read_bytes())
    index = shard[:36] if index_location == "start" else shard[-36:]  # 2 chunks x 16 bytes, a crc32c
    second = struct.unpack_from("<Q", index, 16)[0]
    shard[second + 15] = 0x7f  # the second inner chunk's cbytes ~2 GB
    (path / "c/0/0/0").write_bytes(bytes(shard))
    with pytest.raises(VolumeError, match=r"s.zarr: chunk 'c/0/0/0' \(chunk 1 inside the shard\): the blosc chunk "
                                          r"is damaged \(its header gives 21\d+ compressed bytes"):
        load_volume(path)
    with pytest.raises(VolumeError, match=rf"\(a chunk inside the shard, at byte {second}\): the blosc chunk is "
                                          r"damaged"):
        ZarrSource(open_zarr(path)[0], store=path).read((0, 0, 1), (8, 6, 1))
