"""The viewer's time and fields without a window (dvr_gl/viewer/timeline.py): the player's pace, a step's scene,
the field whose transfer function the editor edits."""

import numpy as np
import pytest

from dvr_gl.apps import render as render_cmd
from dvr_gl.apps.cli import build_parser
from dvr_gl.apps.fields import timed_files
from dvr_gl.transfer_function import preset
from dvr_gl.viewer.keys import help_lines
from dvr_gl.viewer.timeline import Player, at_step, editable, next_editable, with_transfer_function


def blob(cx: float, n: int = 10) -> np.ndarray:
    z, y, x = np.mgrid[0:n, 0:n, 0:n]
    return np.exp(-((x - cx) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2) / 6.0).astype(np.float32)


def source(*argv):
    args = build_parser().parse_args(["view", *map(str, argv)])
    render_cmd.positional_volume(args)
    return render_cmd.source_of(args, "view")


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    folder = tmp_path_factory.mktemp("series")
    for k in range(3):
        np.save(folder / f"step_{k}.npy", blob(2.0 + 3 * k))
    np.save(folder / "other.npy", blob(5.0))
    np.save(folder / "seg.npy", (blob(5.0) > 0.5).astype(np.uint8))
    return folder


def test_the_player_waits_for_each_step_to_be_shown():
    p = Player(3, read_step=lambda k: k, seconds_per_step=0.5)
    assert not p.tick(10.0)                  # paused
    assert p.toggle(10.0) and not p.tick(10.2)  # playing; the next step is due at 10.5
    assert p.tick(10.6)
    assert p.go(1) == 1 and not p.presented
    assert not p.tick(20.0)                  # step 1 not drawn yet: never skipped
    p.presented = True
    assert p.tick(20.0) and p.go(1) == 2 and p.go(1) == 0  # wraps around
    assert p.go(-1) == 2
    assert not p.toggle(21.0) and not p.tick(30.0)  # paused again
    assert not Player(1, read_step=lambda k: k).toggle(0.0)  # one step: nothing to play


def test_a_step_keeps_the_view_and_names_its_step(series, tmp_path):
    """at_step: the step's data and sources, the viewer's camera and transfer function; its saved scene renders
    that step (the screenshot's scene)."""
    src = source(series / "step_*.npy")
    scene = src.load()
    assert timed_files(src, scene, required=False)[0] == 3
    turned = scene.replace(camera=scene.camera.orbited(azimuth=75.0))
    stepped = at_step(turned, src.load(2))
    assert stepped.camera == turned.camera and stepped.transfer_function is turned.transfer_function
    assert np.array_equal(stepped.field.data, np.load(series / "step_2.npy"))
    assert stepped.volume_source.time == 2
    path = tmp_path / "step.toml"
    path.write_text(stepped.to_toml())
    from dvr_gl.scene.resolve import load_scene

    assert np.array_equal(load_scene(path).field.data, stepped.field.data)


def test_no_series_no_player(series):
    src = source(series / "other.npy")
    assert timed_files(src, src.load(), required=False) is None


def test_the_editor_edits_the_chosen_fields_transfer_function(series):
    """Two fields: N moves the editor to the next; an edit replaces that field's function alone."""
    scene = source(series / "step_0.npy", series / "other.npy").load()
    layers = scene.layers
    assert editable(layers) == [0, 1] and next_editable(layers, 0) == 1 and next_editable(layers, 1) == 0
    tf = preset("viridis", layers[1].field.value_range)
    changed = with_transfer_function(scene, 1, tf)
    assert changed.layers[1].transfer_function is tf
    assert changed.layers[0].transfer_function is layers[0].transfer_function
    one = source(series / "other.npy").load()
    assert with_transfer_function(one, 0, tf).transfer_function.points.tolist() == tf.points.tolist()


def test_the_help_lists_the_time_and_field_keys():
    text = "\n".join(help_lines())
    assert "play / pause" in text and "next step" in text and "next field" in text


def test_a_label_maps_table_is_not_edited_as_a_curve(series):
    """A label map first, an image second: the editor starts on the image; a label map alone has nothing to edit
    (the viewer shows its table's colours, and no editor)."""
    labels_first = source("--labels", series / "seg.npy", series / "other.npy").load().layers
    assert [layer.role for layer in labels_first] == ["label", "scalar"]
    assert editable(labels_first) == [1] and next_editable(labels_first, 1) == 1
    assert editable(source("--labels", series / "seg.npy").load().layers) == []
