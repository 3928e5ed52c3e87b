"""Channels and time steps of volume files (issue 42): ImageJ and OME-TIFF hyperstacks, the shared
microscopy files, a glob of 3D files as a series, dvr_gl.io.time_steps; refusals in one line."""

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.fields.layers import FieldSet
from dvr_gl.io import file_axes, load_volume, time_steps

T, Z, C, H, W = 3, 4, 2, 5, 6
# every voxel its own value: 1000 t + 100 z + 10 c + (y * W + x) % 10 (distinct per plane, never 0)
HYPER = (1000 * np.arange(T)[:, None, None, None, None] + 100 * np.arange(Z)[None, :, None, None, None]
         + 10 * np.arange(C)[None, None, :, None, None] + (np.arange(H * W).reshape(H, W) % 10) + 1).astype(np.uint16)


def write_pages(path, pages, description=None, resolution=None):
    """A multi-page grey TIFF of ``pages`` (a list of 2D uint16), the description on every page."""
    import OpenImageIO as oiio

    specs = []
    for p in pages:
        specs.append(oiio.ImageSpec(p.shape[1], p.shape[0], 1, oiio.UINT16))
        if description:
            specs[-1].attribute("ImageDescription", description)
        if resolution:
            specs[-1].attribute("XResolution", float(resolution[0]))
            specs[-1].attribute("YResolution", float(resolution[1]))
            specs[-1].attribute("ResolutionUnit", "none")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs)
    for i, p in enumerate(pages):
        if i:
            assert out.open(str(path), specs[i], "AppendSubimage")
        assert out.write_image(np.ascontiguousarray(p[..., None]))
    out.close()


def imagej_hyperstack(path, data=HYPER, extra=""):
    """``data[t, z, c, y, x]`` as ImageJ writes it: channels fastest, then slices, then frames."""
    t, z, c = data.shape[:3]
    text = (f"ImageJ=1.54f\nimages={t * z * c}\nchannels={c}\nslices={z}\nframes={t}\nhyperstack=true\n"
            f"unit=micron\nspacing=0.75\nfinterval=2.5\n{extra}")
    # OpenImageIO writes one resolution for x and y
    write_pages(path, list(data.reshape(-1, *data.shape[3:])), text, resolution=(4.0, 4.0))
    return path


def test_imagej_hyperstack_channels_and_time(tmp_path):
    """Every channel of the chosen step, each a scalar member, its voxels exactly the step's pages."""
    path = imagej_hyperstack(tmp_path / "h.tif")
    for step in range(T):
        fields = load_volume(path, time=step)
        assert isinstance(fields, FieldSet) and [m.name for m in fields.members] == ["channel 0", "channel 1"]
        for c, m in enumerate(fields.members):
            np.testing.assert_array_equal(m.field.data, HYPER[step, :, c])
            assert m.field.spacing == (0.25, 0.25, 0.75) and m.role == "scalar"
    one = load_volume(path, channel=1, time=2)
    np.testing.assert_array_equal(one.data, HYPER[2, :, 1])
    np.testing.assert_array_equal(load_volume(path, channel=0).data, HYPER[0, :, 0])  # time defaults to 0
    assert time_steps(path) == (T, 2.5)
    assert file_axes(path).channels == C


def test_hyperstack_reads_only_the_pages_of_its_step(tmp_path, monkeypatch):
    """Step k reads the C x Z pages of that step, never another's."""
    from dvr_gl.io import tiff

    path = imagej_hyperstack(tmp_path / "h.tif")
    read = []
    real = tiff._read_pages
    monkeypatch.setattr(tiff, "_read_pages", lambda p, wanted, *rest: read.extend(wanted) or real(p, wanted, *rest))
    load_volume(path, time=1)
    assert sorted(read) == list(range(Z * C, 2 * Z * C))
    read.clear()
    load_volume(path, time=2, channel=1)
    assert read == [2 * Z * C + z * C + 1 for z in range(Z)]


@pytest.mark.parametrize("order", ["XYZCT", "XYCZT", "XYTZC", "XYZTC"])
def test_ome_tiff_dimension_orders_and_names(tmp_path, order):
    """The planes in DimensionOrder (fastest first); channel names from the Channel elements; the voxel size
    in micrometres where the units differ; TimeIncrement in its unit."""
    sizes = {"Z": Z, "C": C, "T": T}
    index = {"Z": 1, "C": 2, "T": 0}  # HYPER's axes
    stored = np.transpose(HYPER, [index[a] for a in reversed(order[2:])] + [3, 4])  # slowest axis first
    xml = (f'<OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0"><Pixels '
           f'DimensionOrder="{order}" SizeX="{W}" SizeY="{H}" SizeZ="{Z}" SizeC="{C}" SizeT="{T}" Type="uint16" '
           f'PhysicalSizeX="0.5" PhysicalSizeY="0.5" PhysicalSizeZ="2" PhysicalSizeZUnit="nm" TimeIncrement="250" '
           f'TimeIncrementUnit="ms"><Channel Name="DAPI"/><Channel Name=""/></Pixels></Image></OME>')
    path = tmp_path / "o.ome.tif"
    write_pages(path, list(stored.reshape(-1, H, W)), xml)
    assert sizes and time_steps(path) == (T, 0.25)
    fields = load_volume(path, time=2)
    assert [m.name for m in fields.members] == ["DAPI", "channel 1"]
    for c, m in enumerate(fields.members):
        np.testing.assert_array_equal(m.field.data, HYPER[2, :, c])
        assert m.field.spacing == pytest.approx((0.5, 0.5, 0.002))


def test_ome_tiff_data_maps_planes_to_pages(tmp_path):
    """TiffData elements, one a plane (as Bio-Formats writes them), in an order of their own."""
    planes = [(t, c, z) for t in range(T) for c in range(C) for z in range(Z)][::-1]  # the pages hold them reversed
    tiffdata = "".join(f'<TiffData FirstZ="{z}" FirstC="{c}" FirstT="{t}" IFD="{i}" PlaneCount="1"/>'
                       for i, (t, c, z) in enumerate(planes))
    xml = (f'<OME><Image><Pixels DimensionOrder="XYZCT" SizeZ="{Z}" SizeC="{C}" SizeT="{T}">{tiffdata}'
           f'</Pixels></Image></OME>')
    path = tmp_path / "o.ome.tif"
    write_pages(path, [HYPER[t, z, c] for t, c, z in planes], xml)
    np.testing.assert_array_equal(load_volume(path, channel=1, time=1).data, HYPER[1, :, 1])


@pytest.mark.parametrize("options, message", [
    (dict(channel=2), r"volume.channel = 2 is past the last channel; the file has 2 \(0 to 1\)"),
    (dict(time=3), r"volume.time = 3 is past the end; the file has 3 time steps \(0 to 2\)"),
])
def test_hyperstack_choice_out_of_range(tmp_path, options, message):
    with pytest.raises(VolumeError, match=message):
        load_volume(imagej_hyperstack(tmp_path / "h.tif"), **options)


def test_plain_stack_has_no_channels_and_one_step(tmp_path):
    path = tmp_path / "s.tif"
    write_pages(path, list(HYPER[0, :, 0]))
    np.testing.assert_array_equal(load_volume(path, time=0).data, HYPER[0, :, 0])
    assert time_steps(path) == (1, None)
    with pytest.raises(VolumeError, match="volume.channel = 0: this file has no channels; remove it"):
        load_volume(path, channel=0)
    with pytest.raises(VolumeError, match=r"volume.time = 1 is past the end; the file has one time step \(0\)"):
        load_volume(path, time=1)


def test_hyperstack_in_a_folder_of_slices_is_refused(tmp_path):
    imagej_hyperstack(tmp_path / "a.tif")
    write_pages(tmp_path / "b.tif", list(HYPER[0, :, 0]))
    with pytest.raises(VolumeError, match="a hyperstack of 2 channels and 3 time points in a folder or glob"):
        load_volume(tmp_path)


# --- the shared microscopy files (../shared/data/microscopy/README.md) ------------------------------------

def _shared(shared_data, name):
    path = shared_data / "microscopy" / name
    if not path.is_file():
        pytest.skip(f"the shared microscopy file {name} is not here")
    return path


def test_shared_confocal_widefield_nucleus(shared_data):
    """Big-endian ZCYX, 2 channels: the README's shape, value ranges and voxel size."""
    path = _shared(shared_data, "xyzc_16bit__dna_conf_wf.tif")
    fields = load_volume(path)
    assert isinstance(fields, FieldSet) and len(fields) == 2
    ranges = [(0, 61711), (608, 7480)]  # C0 confocal, C1 widefield (camera offset 608)
    for m, (lo, hi) in zip(fields.members, ranges):
        assert m.field.dims == (133, 130, 45) and m.field.data.dtype == np.uint16
        assert (int(m.field.data.min()), int(m.field.data.max())) == (lo, hi)
        assert m.field.spacing == pytest.approx((0.51188, 0.51188, 0.49941), rel=1e-4)
    assert time_steps(path) == (1, None)
    np.testing.assert_array_equal(load_volume(path, channel=1).data, fields.members[1].field.data)


def test_shared_dividing_cell_time_series(shared_data):
    """TZCYX, 3 steps of 2 channels: each step read alone; over the steps the README's value ranges, spacing and
    frame interval."""
    path = _shared(shared_data, "CellDivision_T3_Z5_CH2_X240_Y170_TZCYX.tif")
    assert time_steps(path) == (3, pytest.approx(60.075))
    steps = [load_volume(path, time=t) for t in range(3)]
    for c, (lo, hi) in enumerate([(0, 4820), (0, 21118)]):
        values = np.stack([s.members[c].field.data for s in steps])
        assert values.shape == (3, 5, 170, 240) and (int(values.min()), int(values.max())) == (lo, hi)
    assert steps[0].members[0].field.spacing == pytest.approx((0.0905767, 0.0905767, 0.32), rel=1e-6)
    assert not np.array_equal(steps[0].members[1].field.data, steps[2].members[1].field.data)


# --- OME-Zarr: the c and t axes ---------------------------------------------------------------------------

def write_ome_tczyx(path, data=HYPER, labels=("DNA", None), unit="millisecond", chunks=None):
    """An OME-Zarr 0.4 image of ``data[t, z, c, y, x]`` stored TCZYX, one chunk per (t, c) by default; omero
    labels; the t axis' scale 500 in ``unit``."""
    zarr = pytest.importorskip("zarr", reason="zarr reads zarr stores (extra 'zarr')")
    group = zarr.open_group(str(path), mode="w")
    stored = np.ascontiguousarray(data.transpose(0, 2, 1, 3, 4))
    group.create_array("0", data=stored, chunks=chunks or (1, 1) + stored.shape[2:])
    axes = [{"name": "t", "type": "time", "unit": unit}, {"name": "c", "type": "channel"}] + \
        [{"name": a, "type": "space", "unit": "micrometer"} for a in "zyx"]
    scale = {"type": "scale", "scale": [500.0, 1.0, 2.0, 0.5, 0.25]}
    group.attrs["multiscales"] = [{"version": "0.4", "axes": axes,
                                   "datasets": [{"path": "0", "coordinateTransformations": [scale]}]}]
    group.attrs["omero"] = {"channels": [{"label": label} if label else {} for label in labels]}
    return path


def test_ome_zarr_channels_and_time(tmp_path):
    path = write_ome_tczyx(tmp_path / "i.ome.zarr")
    assert time_steps(path) == (T, 0.5)
    fields = load_volume(path, time=2)
    assert [m.name for m in fields.members] == ["DNA", "channel 1"]
    for c, m in enumerate(fields.members):
        np.testing.assert_array_equal(m.field.data, HYPER[2, :, c])
        assert m.field.spacing == (0.25, 0.5, 2.0)
    np.testing.assert_array_equal(load_volume(path, channel=1, time=1).data, HYPER[1, :, 1])
    with pytest.raises(VolumeError, match=r"volume.time = 3 is past the end; the file has 3 time steps"):
        load_volume(path, time=3)
    with pytest.raises(VolumeError, match=r"volume.channel = 5 is past the last channel; the file has 2"):
        load_volume(path, channel=5)


def test_ome_zarr_reads_only_the_chunks_of_its_step(tmp_path):
    """The chunks of every other step are made unreadable: reading step 1 (a channel of it, or all) never
    touches them."""
    path = write_ome_tczyx(tmp_path / "i.ome.zarr")
    for chunk in (path / "0" / "c").rglob("*"):
        if chunk.is_file() and chunk.relative_to(path / "0" / "c").parts[0] != "1":
            chunk.write_bytes(b"not a chunk")
    np.testing.assert_array_equal(load_volume(path, time=1).members[0].field.data, HYPER[1, :, 0])
    np.testing.assert_array_equal(load_volume(path, time=1, channel=1).data, HYPER[1, :, 1])
    with pytest.raises(VolumeError, match="a chunk of the zarr array cannot be read"):
        load_volume(path, time=0)


def test_ome_zarr_out_of_core_one_channel_of_one_step(tmp_path):
    """Out of core reads the chosen channel and step in part; several channels with none chosen: one line."""
    from dvr_gl.scene.resolve import load_scene

    path = write_ome_tczyx(tmp_path / "i.ome.zarr")
    keys = {"volume.path": str(path), "volume.out_of_core": True, "image.width": 8, "image.height": 8}
    scene = load_scene(None, {**keys, "volume.channel": 1, "volume.time": 2})
    assert getattr(scene.volume, "out_of_core", False)
    np.testing.assert_array_equal(scene.volume.read((0, 0, 0), scene.volume.dims), HYPER[2, :, 1])
    with pytest.raises(VolumeError, match="2 channels; out of core reads one channel at a time: choose it"):
        load_scene(None, keys)
    auto = load_scene(None, {**keys, "volume.out_of_core": "auto", "volume.time": 1})  # small: read in memory
    np.testing.assert_array_equal(auto.field.members[1].field.data, HYPER[1, :, 1])


# --- NIfTI 4D and 5D --------------------------------------------------------------------------------------

def write_nifti(path, data_ijk, intent=0, units=(2, 8), pixdim4=2.0, slope=None):
    """A NIfTI-1 of ``data_ijk`` (nibabel's order: x first, then the 4th and 5th axes), spacing (0.5, 1, 2)."""
    nib = pytest.importorskip("nibabel")
    img = nib.Nifti1Image(data_ijk, np.diag([0.5, 1.0, 2.0, 1.0]))
    img.header.set_intent(intent) if intent else None
    img.header.set_xyzt_units(*units)
    zooms = list(img.header.get_zooms())
    if len(zooms) > 3:
        zooms[3] = pixdim4
    img.header.set_zooms(zooms)
    if slope is not None:
        img.header.set_slope_inter(slope, 0.0)
    nib.save(img, str(path))
    return path


def _ijk(data_tzcyx):
    """HYPER-like ``[t, z, c, y, x]`` as nibabel's ``[x, y, z, t, c]``."""
    return np.ascontiguousarray(data_tzcyx.transpose(4, 3, 1, 0, 2))


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_nifti_4d_is_time(tmp_path, suffix):
    path = write_nifti(tmp_path / f"t{suffix}", _ijk(HYPER)[..., 0])
    assert time_steps(path) == (T, 2.0)
    for step in range(T):
        v = load_volume(path, time=step)
        np.testing.assert_array_equal(v.data, HYPER[step, :, 0])
        assert v.spacing == (0.5, 1.0, 2.0)
    with pytest.raises(VolumeError, match="volume.channel = 0: this file has no channels"):
        load_volume(path, channel=0)
    with pytest.raises(VolumeError, match=r"volume.time = 3 is past the end; the file has 3 time steps"):
        load_volume(path, time=3)


@pytest.mark.parametrize("intent", ["vector", "rgb vector"])
def test_nifti_4d_vector_intent_is_channels(tmp_path, intent):
    path = write_nifti(tmp_path / "v.nii", _ijk(HYPER)[:, :, :, 1, :], intent=intent)
    fields = load_volume(path)
    assert [m.name for m in fields.members] == ["channel 0", "channel 1"] and time_steps(path) == (1, None)
    for c, m in enumerate(fields.members):
        np.testing.assert_array_equal(m.field.data, HYPER[1, :, c])
    np.testing.assert_array_equal(load_volume(path, channel=1).data, HYPER[1, :, 1])
    as_time = load_volume(path, fourth_axis="time", time=1)  # the key overrides the intent
    np.testing.assert_array_equal(as_time.data, HYPER[1, :, 1])


def test_nifti_fourth_axis_overrides_and_5d(tmp_path):
    path = write_nifti(tmp_path / "t.nii", _ijk(HYPER)[..., 0])
    fields = load_volume(path, fourth_axis="channel")
    assert len(fields) == T
    np.testing.assert_array_equal(fields.members[2].field.data, HYPER[2, :, 0])
    five = write_nifti(tmp_path / "f.nii.gz", _ijk(HYPER), units=(2, 16), pixdim4=250.0)  # dim[5]: channels
    assert time_steps(five) == (T, 0.25)
    fields = load_volume(five, time=2)
    for c, m in enumerate(fields.members):
        np.testing.assert_array_equal(m.field.data, HYPER[2, :, c])
    np.testing.assert_array_equal(load_volume(five, time=1, channel=0).data, HYPER[1, :, 0])
    with pytest.raises(VolumeError, match="fourth_axis = channel: this 5D file holds its channels in dim"):
        load_volume(five, fourth_axis="channel")
    with pytest.raises(VolumeError, match="fourth_axis must be one of auto, channel, time, got 'space'"):
        load_volume(path, fourth_axis="space")


def test_nifti_scaled_step(tmp_path):
    """scl_slope applies to the step read alone as to a 3D file."""
    path = write_nifti(tmp_path / "s.nii", _ijk(HYPER)[..., 0], slope=0.5)
    np.testing.assert_allclose(load_volume(path, time=2).data, HYPER[2, :, 0] * 0.5)


def test_fourth_axis_applies_to_nifti_only(tmp_path):
    path = tmp_path / "s.tif"
    write_pages(path, list(HYPER[0, :, 0]))
    with pytest.raises(VolumeError, match="volume.fourth_axis applies to nifti; this is tiff"):
        load_volume(path, fourth_axis="time")


def test_scene_key_fourth_axis(tmp_path):
    from dvr_gl.scene.resolve import load_scene

    path = write_nifti(tmp_path / "t.nii", _ijk(HYPER)[..., 0])
    keys = {"volume.path": str(path), "image.width": 8, "image.height": 8}
    np.testing.assert_array_equal(load_scene(None, {**keys, "volume.time": 1}).volume.data, HYPER[1, :, 0])
    scene = load_scene(None, {**keys, "volume.fourth_axis": "channel"})
    assert [layer.name for layer in scene.layers] == ["channel 0", "channel 1", "channel 2"]


# --- a glob of 3D files: a time series --------------------------------------------------------------------

def test_glob_of_volumes_is_a_time_series_in_natural_order(tmp_path):
    """step_2 before step_10; each step one file read alone; the scene's time picks it, in part too."""
    from dvr_gl.scene.resolve import load_scene

    steps = [HYPER[0, :, 0] + k for k in range(12)]
    for k, data in enumerate(steps):
        np.save(tmp_path / f"step_{k}.npy", data)
    pattern = tmp_path / "step_*.npy"
    assert time_steps(pattern) == (12, None)
    for k in (0, 2, 10, 11):
        np.testing.assert_array_equal(load_volume(pattern, time=k).data, steps[k])
    with pytest.raises(VolumeError, match=r"volume.time = 12 is past the end; the glob matches 12 files"):
        load_volume(pattern, time=12)
    scene = load_scene(None, {"volume.path": str(pattern), "volume.time": 10, "image.width": 8, "image.height": 8})
    np.testing.assert_array_equal(scene.volume.data, steps[10])


def test_glob_series_of_raw_read_in_part(tmp_path):
    """A series of raw files out of core: the chosen step's file read in part."""
    from dvr_gl.scene.resolve import load_scene

    for k in range(3):
        (tmp_path / f"s{k}.raw").write_bytes((HYPER[k, :, 0]).astype("<u2").tobytes())
    keys = {"volume.path": str(tmp_path / "s*.raw"), "volume.dims": [W, H, Z], "volume.dtype": "uint16",
            "volume.out_of_core": True, "volume.time": 2, "image.width": 8, "image.height": 8}
    scene = load_scene(None, keys)
    np.testing.assert_array_equal(scene.volume.read((0, 0, 0), scene.volume.dims), HYPER[2, :, 0])


def test_glob_of_tiff_stays_slices_and_mixed_globs_are_not_series(tmp_path):
    from dvr_gl.io import detect_format

    for k in range(2):
        write_pages(tmp_path / f"s{k}.tif", [HYPER[0, k, 0]])
    assert detect_format(tmp_path / "s*.tif") == "tiff"
    np.testing.assert_array_equal(load_volume(tmp_path / "s*.tif").data, HYPER[0, :2, 0])
    np.save(tmp_path / "s9.npy", HYPER[0, :, 0])
    assert detect_format(tmp_path / "s*") == "tiff"  # two formats: not a series (read as slices, which refuse)
    with pytest.raises(VolumeError):
        load_volume(tmp_path / "s*")


# --- TIFF pages of colour: a colour volume with volume.role = "rgb" ---------------------------------------

def test_rgb_tiff_pages_are_a_colour_volume_by_role(tmp_path):
    """Pages of 3 samples: refused as scalars (naming the role that reads them), a ColorVolume with role rgb whose
    colour is the sRGB-decoded codes (dvr_gl.fields.color)."""
    import OpenImageIO as oiio

    from dvr_gl.fields.color import ColorVolume, srgb_decode

    rgb = (np.arange(2 * 3 * 4 * 3, dtype=np.uint8).reshape(2, 3, 4, 3) * 3)  # [z, y, x, rgb]
    path = tmp_path / "c.tif"
    specs = [oiio.ImageSpec(4, 3, 3, oiio.UINT8) for _ in range(2)]
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs)
    for k in range(2):
        if k:
            assert out.open(str(path), specs[k], "AppendSubimage")
        assert out.write_image(np.ascontiguousarray(rgb[k]))
    out.close()
    with pytest.raises(VolumeError, match=r"page 0 has 3 samples per pixel; .* \(set volume.role = rgb to read"):
        load_volume(path)
    colour = load_volume(path, role="rgb")
    assert isinstance(colour, ColorVolume) and colour.dims == (4, 3, 2)
    np.testing.assert_allclose(colour.colour, srgb_decode(rgb), atol=1e-6)
    with pytest.raises(VolumeError, match="volume.role = rgb: page 0 has 1 samples per pixel"):
        load_volume(imagej_hyperstack(tmp_path / "h.tif"), role="rgb", channel=0)


def test_nifti_colour_by_role(tmp_path):
    """RGB24 voxels, and an RGB vector (intent 2003) in dim[4], read as a colour volume with volume.role = rgb;
    RGB24 without the role, and a vector of 2, refused in one line."""
    nib = pytest.importorskip("nibabel")
    from dvr_gl.fields.color import ColorVolume, srgb_decode

    codes = (np.arange(4 * 3 * 2 * 3).reshape(4, 3, 2, 3) * 3).astype(np.uint8)  # [i, j, k, rgb]
    rgb24 = np.zeros((4, 3, 2), dtype=[("R", "u1"), ("G", "u1"), ("B", "u1")])
    for k, n in enumerate("RGB"):
        rgb24[n] = codes[..., k]
    nib.save(nib.Nifti1Image(rgb24, np.eye(4)), str(tmp_path / "c.nii"))
    vector = write_nifti(tmp_path / "v.nii", codes, intent="rgb vector")
    expected = srgb_decode(codes.transpose(2, 1, 0, 3))
    for path in (tmp_path / "c.nii", vector):
        colour = load_volume(path, role="rgb")
        assert isinstance(colour, ColorVolume) and colour.dims == (4, 3, 2)
        np.testing.assert_allclose(colour.colour, expected, atol=1e-6)
    with pytest.raises(VolumeError, match="holds a colour a voxel .* volume.role = rgb"):
        load_volume(tmp_path / "c.nii")
    with pytest.raises(VolumeError, match="this one has 2 components: give it the role scalar"):
        load_volume(write_nifti(tmp_path / "two.nii", codes[..., :2], intent="vector"), role="rgb")


def test_ome_tiff_of_rgb_pages(tmp_path):
    """OME's SizeC counts samples: an RGB OME-TIFF (one Channel of SamplesPerPixel 3, SizeC 3) is one plane a
    slice, read as a colour volume with volume.role = rgb."""
    import OpenImageIO as oiio

    from dvr_gl.fields.color import ColorVolume

    xml = ('<OME><Image><Pixels DimensionOrder="XYCZT" SizeX="4" SizeY="3" SizeZ="2" SizeC="3" SizeT="1">'
           '<Channel SamplesPerPixel="3"/></Pixels></Image></OME>')
    path = tmp_path / "rgb.ome.tif"
    specs = []
    for _ in range(2):
        specs.append(oiio.ImageSpec(4, 3, 3, oiio.UINT8))
        specs[-1].attribute("ImageDescription", xml)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs)
    for k in range(2):
        if k:
            assert out.open(str(path), specs[k], "AppendSubimage")
        assert out.write_image(np.full((3, 4, 3), 40 * k, np.uint8))
    out.close()
    colour = load_volume(path, role="rgb")
    assert isinstance(colour, ColorVolume) and colour.dims == (4, 3, 2)


def test_ome_zarr_each_channel_and_step_has_its_own_block_ranges(tmp_path):
    """Out of core, each channel and step keeps its own block ranges and sidecar: channel 1 never takes channel
    0's (whose values are lower: a block would be skipped as empty where it is not)."""
    from dvr_gl.out_of_core import open_volume

    path = write_ome_tczyx(tmp_path / "i.ome.zarr")
    for t, c in [(0, 0), (0, 1), (2, 1), (2, 0), (0, 1)]:  # the last reads the sidecar channel 1 wrote
        v = open_volume(path, out_of_core=True, channel=c, time=t)
        step = HYPER[t, :, c]
        assert v.value_range == (float(step.min()), float(step.max()))
    sidecars = sorted(p.name for p in tmp_path.glob("*dvr-ranges*"))
    assert len(sidecars) == 4 and all(".pick" in name for name in sidecars), sidecars
