"""``dvr bench peers`` at tiny sizes, without the peers' environment: dvr-gl's rows, the error against
the converged reference, and the worker's scene description (camera, box, transfer function, image
layout) checked against dvr-gl through the worker's numpy stub peer."""

import math
import sys

import numpy as np
import pytest

from dvr_gl.apps.cli import main
from dvr_gl.bench import peer_worker, peers
from dvr_gl.scene.resolve import load_scene

TINY = {"size": 16, "volume_size": 12, "rounds": 1, "frames": 1, "error_size": 12}


def label(row) -> str:
    """A row's setting, dvr-gl's defaults without the distance the scene chose for them (issue 44)."""
    return "defaults" if row["setting"].startswith("defaults (") else row["setting"]


@pytest.fixture
def short_sweep(monkeypatch):
    """dvr-gl's defaults and one more distance: fewer fresh processes."""
    monkeypatch.setattr(peers, "SWEEP", (2.0,))
    monkeypatch.setattr(peers, "PREINTEGRATED_SWEEP", ())
    monkeypatch.setattr(peers, "REFINED_SWEEP", ())


def test_worker_matrices_send_dvr_gl_rays_through_pixel_centres(tmp_path):
    """The view and projection the peers are given map every dvr-gl pixel ray to its pixel's centre
    (row 0 at the top; a wide image, so that the aspect and the vertical field of view are told apart)."""
    volume = peers.volume_file("blobs", 9, tmp_path)
    keys = {**peers.scene_keys("blobs-mip", volume, 16), "image.width": 24, "image.height": 10}
    scene = peers.peer_scene(keys, "mip")
    camera = load_scene(None, keys).camera
    origins, directions = camera.pixel_rays(24, 10)
    centres = np.stack(np.meshgrid(np.arange(24) + 0.5, np.arange(10) + 0.5), axis=-1).reshape(-1, 2)
    for depth in (10.0, 40.0):
        projected = peer_worker.project(origins + depth * directions, scene, 24, 10)
        assert np.abs(projected - centres).max() < 1e-6
    near, far = peer_worker.depth_range(scene)
    lo, hi = peer_worker.box(scene)
    assert np.allclose(hi - lo, 8.0) and 0 < near < far  # node-centred: the hull of 9 samples is 8 wide
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cam = scene["camera"]
    forward, _, _ = peer_worker.camera_basis(cam["eye"], cam["target"], cam["up"])
    depths = (corners - scene["camera"]["eye"]) @ forward
    assert near < depths.min() and depths.max() < far


def test_from_framebuffer_flips_and_decodes():
    """A bottom-up 8-bit sRGB framebuffer becomes dvr-gl's layout: row 0 on top, linear colour, alpha as is."""
    fb = np.zeros((2, 1, 4), np.uint8)
    fb[0, 0] = (255, 255, 255, 255)  # the bottom row
    fb[1, 0] = (188, 0, 0, 128)      # the top row: sRGB 188 is linear 0.5
    image = peer_worker.from_framebuffer(fb, bottom_up=True, srgb=True)
    assert image.dtype == np.float32 and image.shape == (2, 1, 4)
    assert abs(image[0, 0, 0] - 0.5) < 5e-3 and abs(image[0, 0, 3] - 128 / 255) < 1e-6
    assert np.allclose(image[1, 0], 1.0)


def test_classify_is_piecewise_linear_and_constant_beyond():
    points = [[10, 0, 0, 0, 0], [20, 1, 0.5, 0, 1]]
    rgba = peer_worker.classify(points, [0, 15, 30])
    assert np.allclose(rgba, [[0, 0, 0, 0], [0.5, 0.25, 0, 0.5], [1, 0.5, 0, 1]])


def test_stub_peer_sees_what_dvr_gl_sees(tmp_path, monkeypatch):
    """The numpy stub peer renders from the worker's scene description alone (its camera, box and
    transfer function helpers), in the worker, as a peer would: at the same sample distance its images
    match dvr-gl's, composite and MIP, so the description means what dvr-gl means.  Its rows and ratio
    rows come out like a real peer's."""
    monkeypatch.setattr(peers, "SWEEP", (1.0,))  # the stub's distance
    monkeypatch.setattr(peers, "PREINTEGRATED_SWEEP", ())
    monkeypatch.setattr(peers, "REFINED_SWEEP", ())
    rows, ratio_rows, notes, images = peers.run(("dvr-gl", "numpy"), ("ml-composite", "ml-mip"),
                                                peers_python=sys.executable, cache=tmp_path / "cache",
                                                work=tmp_path / "work", **TINY)
    assert [(r["scene"], r["renderer"], label(r)) for r in rows] == [
        (s, r, d) for s in ("ml-composite", "ml-mip")
        for r, d in (("dvr-gl", "defaults"), ("dvr-gl", "1 voxel"), ("numpy", "1 voxel"))]
    chosen = next(r for r in rows if r["setting"].startswith("defaults"))  # the row names the distance chosen
    assert chosen["setting"] == f"defaults ({chosen['settings']['sample_distance_voxels']:.3g} voxel)"
    for key in ("ml-composite", "ml-mip"):
        ours, stub = images[(key, "dvr-gl", "1 voxel")], images[(key, "numpy", "1 voxel")]
        for a, b in zip(ours, stub):
            assert a.shape == b.shape and a[..., 3].max() > 0.05
            # dvr-gl stops rays early (renderer.ert_threshold) and interpolates its table; the stub does neither
            assert np.abs(a - b).max() < 0.02, (key, np.abs(a - b).max())
    stub_rows = [r for r in rows if r["renderer"] == "numpy"]
    assert all(r["psnr"] > 25 and math.isfinite(r["ms"]) for r in stub_rows)
    assert [(r["scene"], r["peer"]) for r in ratio_rows] == [("ml-composite", "numpy"), ("ml-mip", "numpy")]
    for r in ratio_rows:
        assert r["ratio_1vox"] == pytest.approx(r["peer_ms"] / next(
            x["ms"] for x in rows
            if x["scene"] == r["scene"] and x["setting"] == "1 voxel" and x["renderer"] == "dvr-gl"))
    assert any("computed" in n for n in notes)


def test_bench_peers_with_dvr_gl_only(tmp_path, capsys, short_sweep):
    """Without a peers environment: dvr-gl's rows, each peer listed as not installed (a note, not an
    error), the reference cached, the Markdown written."""
    md = tmp_path / "peers.md"
    args = ["bench", "peers", "--scenes", "blobs-mip", "--volume-size", "12", "--size", "16", "--error-size", "12",
            "--rounds", "1", "--frames", "2", "--cache", str(tmp_path / "cache"), "--renderers", "dvr-gl,vtk-gpu",
            "--peers-python", str(tmp_path / "absent-python")]
    assert main(args) == 1  # a named interpreter must exist
    assert "no such interpreter" in capsys.readouterr().err
    args = args[:-1] + [sys.executable, "--markdown", str(md), "--pictures", str(tmp_path)]  # no peers there
    assert main(args) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("blobs-mip ")]
    assert [r[1:3] for r in rows] == [["dvr-gl", "defaults"], ["dvr-gl", "2"]]
    assert rows[0][3].startswith("(")  # the distance the scene chose (issue 44)
    psnr = [float(r[-2]) for r in rows]
    assert all(20 < p < 200 for p in psnr), psnr
    for name in ("peers-blobs-mip.png", "peers-blobs-mip-error.png", "peers-blobs-mip.txt"):
        assert (tmp_path / name).stat().st_size > 0
    assert "vtk-gpu: not installed" in out and "computed in" in out
    assert md.read_text().startswith("<!-- written by `dvr bench peers")
    assert main(args[:-4] + ["--renderers", "dvr-gl"]) == 0
    assert "cached " in capsys.readouterr().out  # the converged reference is not computed twice


def test_ratios_pick_the_fastest_dvr_gl_setting_at_the_peers_error():
    rows = [{"scene": "s", "renderer": "dvr-gl", "setting": f"{d:g} voxel", "voxels": d, "ms": ms, "psnr": p}
            for d, ms, p in ((0.5, 40.0, 50.0), (1.0, 20.0, 44.8), (2.0, 10.0, 38.0))]
    rows += [{"scene": "s", "renderer": "peer", "setting": "1 voxel", "voxels": None, "ms": 30.0, "psnr": 45.0},
             {"scene": "s", "renderer": "sharp", "setting": "1 voxel", "voxels": None, "ms": 30.0, "psnr": 60.0}]
    peer, sharp = peers.ratios(rows)
    assert peer["dvrgl"] == "1 voxel" and peer["ratio"] == pytest.approx(1.5)  # 44.8 >= 45 - 0.5
    assert peer["ratio_1vox"] == pytest.approx(1.5)
    assert sharp["dvrgl"] == "none of the sweep" and sharp["ratio"] is None
    assert peer["defaults_ms"] is None  # no defaults row here
    rows[0]["setting"] = "defaults (0.5 voxel)"  # the defaults against each peer (issue 44)
    peer = peers.ratios(rows)[0]
    assert (peer["defaults_ms"], peer["defaults_psnr"], peer["defaults_ratio"]) == (40.0, 50.0, 0.75)


def test_outline_mask_is_the_ring_around_the_box(tmp_path):
    """The pixels left out of "PSNR off the outline": a thin ring where rays go from missing the box to
    hitting it; not the image's corners (empty) nor its centre (inside)."""
    volume = peers.volume_file("blobs", 9, tmp_path)
    mask = peers.outline_mask(peers.scene_keys("blobs-mip", volume, 16), 32)
    assert mask.shape == (32, 32) and 0.05 < mask.mean() < 0.4
    assert not mask[0, 0] and not mask[-1, -1] and not mask[16, 16]
    assert peers.psnr(np.ones((2, 2, 4)), np.ones((2, 2, 4))) == math.inf
    a, b = np.zeros((2, 2, 4)), np.zeros((2, 2, 4))
    b[0, 0] = 0.5  # only in the pixel left out
    keep = np.ones((2, 2), bool)
    keep[0, 0] = False
    assert peers.psnr(a, b, keep) == math.inf and peers.psnr(a, b) < 20


def test_ct_scene_is_left_out_without_the_datasets(tmp_path, short_sweep):
    """(the other scene with the short sweep: its rows only show that it alone was measured)"""
    rows, ratio_rows, notes, images = peers.run(("dvr-gl",), ("cthead-bone", "blobs-mip"), data_dir=tmp_path,
                                                cache=tmp_path / "cache", work=tmp_path / "work", **TINY)
    assert {r["scene"] for r in rows} == {"blobs-mip"}
    assert any(n.startswith("cthead-bone: regular/cthead.nhdr not found") for n in notes)
    assert list(images["references"]) == ["blobs-mip"]


def test_ct_scene_means_the_same_to_a_peer(tmp_path, monkeypatch, shared_data):
    """CThead (int16, spacing 1 x 1 x 2 mm, bone TF in the file's units): the worker's description
    (spacing, value range, camera up) renders in the numpy stub as in dvr-gl at the same distance."""
    monkeypatch.setattr(peers, "SWEEP", (1.0,))
    monkeypatch.setattr(peers, "PREINTEGRATED_SWEEP", ())
    monkeypatch.setattr(peers, "REFINED_SWEEP", ())
    rows, _, notes, images = peers.run(("dvr-gl", "numpy"), ("cthead-bone",), data_dir=shared_data,
                                       peers_python=sys.executable, cache=tmp_path / "cache",
                                       work=tmp_path / "work", **TINY)
    assert [(r["renderer"], label(r)) for r in rows] == [
        ("dvr-gl", "defaults"), ("dvr-gl", "1 voxel"), ("numpy", "1 voxel")]
    job = peers.peer_scene(peers.scene_keys("cthead-bone", tmp_path / "work" / "cthead.npy", 16,
                                            peers.dataset_file("cthead", shared_data, tmp_path / "work")[1]),
                           "composite")
    assert job["dims"] == [256, 256, 113] and job["spacing"] == [1.0, 1.0, 2.0] and job["value_range"][0] < 1024
    ours, stub = images[("cthead-bone", "dvr-gl", "1 voxel")], images[("cthead-bone", "numpy", "1 voxel")]
    for a, b in zip(ours, stub):
        assert a[..., 3].max() > 0.5  # the skull is there
        assert np.abs(a - b).max() < 0.02, np.abs(a - b).max()  # as for the phantoms above


def test_bench_peers_sweep_option(tmp_path, capsys):
    """--sweep names dvr-gl's sample distances; anything but positive numbers is refused in one line."""
    base = ["bench", "peers", "--scenes", "blobs-mip", "--volume-size", "10", "--size", "12", "--error-size", "10",
            "--rounds", "1", "--frames", "1", "--cache", str(tmp_path / "cache"), "--renderers", "dvr-gl"]
    for bad in ("abc", "2,-1", "nan"):
        assert main(base + ["--sweep", bad]) == 1
        err = capsys.readouterr().err
        assert "--sweep" in err and "internal error" not in err
    assert main(base + ["--sweep", "3"]) == 0
    settings = [line.split()[2:4] for line in capsys.readouterr().out.splitlines() if line.startswith("blobs-mip ")]
    assert [s[0] for s in settings] == ["defaults", "3", "3"] and settings[1][1] == "voxel"
    assert settings[2] == ["3", "voxel"]  # refined (MIP), the column cut at two words


def test_pre_integrated_points_are_run_on_composite_scenes_only(tmp_path, monkeypatch):
    """The pre-integrated sweep is measured where classification matters (emission-absorption), its
    images differ from the post-classified ones at the same distance, and the ratio to "1 voxel" is to
    the post-classified row; the refined sweep (the extremum refined between samples) on MIP only."""
    monkeypatch.setattr(peers, "SWEEP", (1.0, 4.0))
    monkeypatch.setattr(peers, "PREINTEGRATED_SWEEP", (4.0,))
    monkeypatch.setattr(peers, "REFINED_SWEEP", (4.0,))
    rows, ratio_rows, _, images = peers.run(("dvr-gl",), ("blobs-composite", "blobs-mip"), cache=tmp_path / "cache",
                                            work=tmp_path / "work", **TINY)
    settings = {s: [label(r) for r in rows if r["scene"] == s] for s in ("blobs-composite", "blobs-mip")}
    assert settings["blobs-composite"] == ["defaults", "1 voxel", "4 voxel", "4 voxel pre-integrated"]
    assert settings["blobs-mip"] == ["defaults", "1 voxel", "4 voxel", "4 voxel refined"]
    post = images[("blobs-composite", "dvr-gl", "4 voxel")][0]
    pre = images[("blobs-composite", "dvr-gl", "4 voxel pre-integrated")][0]
    assert np.abs(post - pre).max() > 1e-4
    plain = images[("blobs-mip", "dvr-gl", "4 voxel")][0]
    refined = images[("blobs-mip", "dvr-gl", "4 voxel refined")][0]
    assert np.abs(plain - refined).max() > 1e-4


def test_the_scenes_new_to_the_defaults(tmp_path):
    """Issue 44's scenes: the Shepp-Logan phantom with its own transfer function, and the MNI152 MIP with a
    ramp over the template's range, left out with a note where the shared data is not there."""
    keys = peers.scene_keys("shepp-composite", peers.volume_file("shepp-logan", 9, tmp_path), 16)
    assert keys["transfer_function.points"] == peers.COMPOSITE_TF["shepp-logan"]
    assert keys["renderer.compositing"] == "emission_absorption"
    rows, _, notes, _ = peers.run(("dvr-gl",), ("mri-mip",), data_dir=tmp_path, cache=tmp_path / "cache",
                                  work=tmp_path / "work", **TINY)
    assert rows == [] and any(n.startswith("mri-mip: regular/MNI152_2009_template.nii.gz not found") for n in notes)
    assert peers.MIP_TFS["mni152"][-1][0] == 1570  # the template's maximum


def test_help_lists_the_scenes_and_renderers_of_the_code(capsys, monkeypatch):
    """``--scenes`` and ``--renderers`` name what peers.SCENES and peers.RENDERERS hold (not a hand-kept list)."""
    monkeypatch.setenv("COLUMNS", "1000")  # argparse wraps at hyphens otherwise
    with pytest.raises(SystemExit):
        main(["bench", "peers", "--help"])
    text = capsys.readouterr().out
    for name in (*peers.SCENES, *peers.RENDERERS):
        assert name in text, name


@pytest.mark.parametrize("name", ["held-out", "held-out-2", "held-out-3"])
def test_the_held_out_scenes_are_declared_whole(tmp_path, capsys, name):
    """Issue 44's held-out scenes (the three sets): each on a dataset the bench can load, with a transfer
    function for its mode; ``--scenes held-out`` (``held-out-2``, ``held-out-3``) names exactly them, and
    without the shared data they are left out with a note each (nothing measured, one line on stderr)."""
    held = peers.HELD_OUT_SETS[name]
    for key in held:
        dataset, mode = peers.SCENES[key]
        assert dataset in peers.DATASETS, key
        assert mode == "mip" or dataset in peers.COMPOSITE_TF, key  # MIP: the uint8 ramp unless MIP_TFS has one
    args = ["bench", "peers", "--scenes", name, "--renderers", "dvr-gl", "--data-dir", str(tmp_path),
            "--cache", str(tmp_path / "cache"), "--rounds", "1", "--frames", "1", "--size", "16", "--error-size", "12"]
    assert main(args) == 1  # nothing measured: no data
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "no scene was measured" in err and "internal error" not in err
    left_out = [line.split(":")[0] for line in out.splitlines() if line.endswith("(--data-dir), left out")]
    assert left_out == list(held)  # exactly the set, in its order
    for key in held:
        assert f"{key}: {peers.DATASETS[peers.SCENES[key][0]][0]} not found" in out, key


def test_the_help_says_which_scenes_each_held_out_set_is(capsys, monkeypatch):
    """The help's "the last N" and "the N before them" are true of peers.SCENES: the third set last, the
    second just before it, the first before that; the sets share no scene, the second and the third are
    three composite, three MIP each, and no (dataset, mode) of the third was a scene before it."""
    first, second, third = list(peers.HELD_OUT), list(peers.HELD_OUT_2), list(peers.HELD_OUT_3)
    scenes = list(peers.SCENES)
    assert scenes[-len(third):] == third
    assert scenes[-len(third) - len(second):-len(third)] == second
    assert scenes[-len(third) - len(second) - len(first):-len(third) - len(second)] == first
    assert len(set(first + second + third)) == len(first + second + third)
    for held in (second, third):
        assert sorted(peers.SCENES[k][1] for k in held) == ["composite"] * 3 + ["mip"] * 3
    before = {peers.SCENES[k] for k in scenes[:-len(third)]}
    assert not {peers.SCENES[k] for k in third} & before
    monkeypatch.setenv("COLUMNS", "1000")
    with pytest.raises(SystemExit):
        main(["bench", "peers", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f'"held-out" for the {len(first)} before the last {len(second) + len(third)}' in text
    assert f'"held-out-2" for the {len(second)} before the last {len(third)}' in text
    assert f'"held-out-3" for the last {len(third)}' in text


#: The second held-out set as read from the shared data: dataset -> (zyx shape, dtype, spacing x y z).
HELD_OUT_2_VOLUMES = {"frog": ((136, 470, 500), np.uint8, (1.0, 1.0, 1.5)),
                      "mni152": ((193, 229, 193), np.int16, (1.0, 1.0, 1.0)),
                      "brainsmall": ((84, 128, 128), np.uint8, (1.0, 1.0, 1.0)),
                      "lobster": ((56, 324, 301), np.uint8, (1.0, 1.0, 1.4)),
                      "cthead": ((113, 256, 256), np.int16, (1.0, 1.0, 2.0)),
                      "cell": ((5, 170, 240), np.uint16, (0.0906, 0.0906, 0.32))}


def loaded_held_out(keys, volumes: dict, shared_data, tmp_path):
    """Each held-out scene of ``keys`` loaded as the ``.npy`` the bench and the peers read, checked against
    ``volumes`` (dataset -> zyx shape, dtype, spacing x y z; exactly the set's datasets): ``(key, dataset,
    mode, path, extra keys, data)``."""
    assert {peers.SCENES[k][0] for k in keys} == set(volumes)
    for key in keys:
        dataset, mode = peers.SCENES[key]
        path, extra = peers.dataset_file(dataset, shared_data, tmp_path)
        data = np.load(path)
        shape, dtype, spacing = volumes[dataset]
        assert data.shape == shape and data.dtype == dtype, key
        assert np.allclose(extra["volume.spacing"], spacing, rtol=1e-3), key
        yield key, dataset, mode, path, extra, data


def test_the_second_held_out_set_loads_from_its_datasets(tmp_path, shared_data):
    """Each scene of the second set loads (load only: these scenes are never rendered outside the one run
    after the defaults change) as the ``.npy`` the bench and the peers read, in the file's own type and
    spacing; each transfer function's knots rise within the data's range, its last knot at or below the
    maximum; the MIP ramps end between the 99.5th percentile and the maximum, as a contrast limit would."""
    for key, dataset, mode, path, extra, data in loaded_held_out(peers.HELD_OUT_2, HELD_OUT_2_VOLUMES, shared_data,
                                                                tmp_path):
        points = peers.scene_keys(key, path, 16, extra)["transfer_function.points"]
        knots = [p[0] for p in points]
        assert knots == sorted(knots) and knots[0] == 0 and knots[-1] <= data.max(), key
        if mode == "mip":
            assert points == peers.MIP_TFS[dataset], key
            assert np.percentile(data, 99.5) < knots[-1] <= data.max(), key
        else:
            assert points == peers.COMPOSITE_TF[dataset] and max(p[4] for p in points) < 1, key


def test_the_chromosome_scene_reads_one_channel_at_one_time_point(tmp_path, shared_data):
    """The dividing cell's file holds 3 time points of 2 channels (TZCYX); the scene renders the chromosome
    channel (0) at the second time point, exactly those voxels of the file."""
    import tifffile

    path, _ = peers.dataset_file("cell", shared_data, tmp_path)
    with tifffile.TiffFile(shared_data / peers.DATASETS["cell"][0]) as tif:
        assert tif.series[0].axes == "TZCYX"
        stack = tif.series[0].asarray()
    assert np.array_equal(np.load(path), stack[1, :, 0])
    assert not np.array_equal(stack[1, :, 0], stack[0, :, 0]) and not np.array_equal(stack[1, :, 0], stack[1, :, 1])


#: The third held-out set as read from the shared data: dataset -> (zyx shape, dtype, spacing x y z).
HELD_OUT_3_VOLUMES = {"bunny": ((361, 512, 512), np.int16, (0.337891, 0.337891, 0.5)),
                      "ironProt": ((68, 68, 68), np.uint8, (1.0, 1.0, 1.0)),
                      "widefield": ((45, 130, 133), np.uint16, (0.5119, 0.5119, 0.4994)),
                      "neghip": ((66, 66, 66), np.uint8, (1.0, 1.0, 1.0)),
                      "headsq": ((93, 64, 64), np.uint16, (3.2, 3.2, 1.5)),
                      "spindle": ((5, 170, 240), np.uint16, (0.0906, 0.0906, 0.32))}
#: Where the third set's composite knots come from: the voxels the percentiles were taken of, and the
#: percentile at each knot after the first (None: the maximum), as the comments in peers.py say.
HELD_OUT_3_KNOTS = {"bunny": (lambda d: d[d > -2000], (90, 95, 99, 99.9, None)),
                    "ironProt": (lambda d: d[d > 0], (50, 75, 90, 95, None)),
                    "widefield": (lambda d: d, (75, 90, 95, 99, 99.9, None))}


@pytest.mark.slow  # the CT bunny: 190 MB from a bzip2 stream
def test_the_third_held_out_set_loads_from_its_datasets(tmp_path, shared_data):
    """Each scene of the third set loads (load only: these scenes are never rendered before the one run) as
    the ``.npy`` the bench and the peers read, in the file's own type and spacing.  The composite knots sit
    at the percentiles the comments name (numpy's, rounded to the data's integers), clear below the second
    knot, alpha below 1, per one voxel (the smallest spacing, for the bench and the peers alike); the MIP
    ramps end at the 99.9th percentile rounded to 1 % of the maximum, as a contrast limit would."""
    for key, dataset, mode, path, extra, data in loaded_held_out(peers.HELD_OUT_3, HELD_OUT_3_VOLUMES, shared_data,
                                                                tmp_path):
        keys = peers.scene_keys(key, path, 16, extra)
        points = keys["transfer_function.points"]
        knots = [p[0] for p in points]
        assert knots == sorted(knots) and knots[0] <= data.min() and knots[-1] <= data.max(), key
        if mode == "mip":
            assert points == peers.MIP_TFS[dataset] and len(points) == 2 and points[0][0] == 0, key
            assert abs(knots[-1] - np.percentile(data, 99.9)) <= 0.01 * data.max(), key
            continue
        assert points == peers.COMPOSITE_TF[dataset], key
        voxels, at = HELD_OUT_3_KNOTS[dataset]
        voxels = voxels(data)
        want = [voxels.max() if q is None else np.rint(np.percentile(voxels, q)) for q in at]
        assert knots[-len(at):] == want, key
        alphas = [p[4] for p in points]
        assert alphas[:2] == [0.0, 0.0] and max(alphas) < 1, key
        unit = min(HELD_OUT_3_VOLUMES[dataset][2])
        assert keys["transfer_function.unit_distance"] == pytest.approx(unit, rel=1e-3), key
        assert peers.peer_scene(keys, mode)["unit_distance"] == keys["transfer_function.unit_distance"], key


@pytest.mark.parametrize("dataset, time, channel", [("widefield", None, 1), ("spindle", 2, 1)])
def test_the_third_sets_microscopy_scenes_read_their_channel(tmp_path, shared_data, dataset, time, channel):
    """The widefield scene renders channel 1 of the confocal-versus-widefield stack (ZCYX), the spindle scene
    channel 1 of the dividing cell at its third time point (TZCYX): exactly those voxels of the file, not
    the channel or the time point the earlier sets used."""
    import tifffile

    path, _ = peers.dataset_file(dataset, shared_data, tmp_path)
    with tifffile.TiffFile(shared_data / peers.DATASETS[dataset][0]) as tif:
        stack = tif.series[0].asarray()
    want = stack[:, channel] if time is None else stack[time, :, channel]
    assert np.array_equal(np.load(path), want)
    other = stack[:, 0] if time is None else stack[1, :, 0]  # the DNA scene's, the chromosome scene's
    assert not np.array_equal(want, other)


def test_the_dna_scene_reads_one_channel(tmp_path, shared_data):
    """The confocal stack holds two channels; the held-out MIP scene renders the DNA one (16-bit, 45
    planes of 130 x 133, about half a micron a sample), and its ramp ends near the channel's 99.9th
    percentile, as a contrast limit would."""
    path, extra = peers.dataset_file("dna", shared_data, tmp_path)
    data = np.load(path)
    assert data.shape == (45, 130, 133) and data.dtype == np.uint16
    assert 0.49 < min(extra["volume.spacing"]) < 0.52
    top = peers.MIP_TFS["dna"][-1][0]
    assert np.percentile(data, 99.5) < top < data.max()


def test_an_unknown_scene_is_refused_naming_the_sets(capsys):
    """An unknown scene is refused in one line that lists the scenes and the held-out sets' names."""
    assert main(["bench", "peers", "--scenes", "held-out,bogus", "--renderers", "dvr-gl"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown bogus" in err and "internal error" not in err
    assert all(name in err for name in ("ml-composite", "spindle-mip", "held-out, held-out-2, held-out-3"))
