"""Conformance of every registered renderer, generated from the registry: no hand-kept lists.

For each renderer, each data kind and each compositing mode it declares, in perspective and
orthographic views:

* **oracle**: the renderer against its own same-discretization oracle (its plugin's ``oracle``; the
  CPU references have none: they are the judges), on the 16^3 phantom, with the float32 assertion of
  the other renderer tests (``conftest.assert_close``);
* **closed forms** (``closed_forms.py``): a homogeneous box, an extinction ramp and a sphere (sampled
  on a grid, and analytic), against their exact images, within the bound the renderer's plugin
  declares for each (``tolerances``: the largest absolute error outside the exact bounds, measured and
  justified in the plugin).  A renderer that declares no bound for a closed form fails, naming the
  error it measured, until it does.

A renderer registered from another package is tested here the day it is installed
(``tests/renderers/test_plugins.py`` shows it).
"""

import numpy as np
import pytest

from closed_forms import CLOSED_FORMS, HEIGHT, VIEWS, WIDTH, error_outside, own_filter
from conftest import assert_close
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.scene.resolve import load_scene

PLUGINS = registry.plugins()


def _kinds(plugin):
    """The data kinds a renderer declares (any field: every kind the closed forms have)."""
    every = sorted({cf.kind for cf in CLOSED_FORMS.values()})
    return every if plugin.data_kinds is None else [k for k in every if k in plugin.data_kinds]


def _cases_closed_forms():
    for name, plugin in PLUGINS.items():
        modes = plugin.choices("compositing")
        for cf in CLOSED_FORMS.values():
            if cf.kind not in _kinds(plugin):
                continue
            for mode in cf.modes:
                if mode in modes:
                    for view in (v for v in VIEWS if v in plugin.projections):
                        yield pytest.param(name, cf.name, mode, view, id=f"{name}-{cf.name}-{mode}-{view}")


def _cases_oracle():
    for name, plugin in PLUGINS.items():
        if plugin.oracle is None:
            continue
        for mode in plugin.choices("compositing"):
            for view in (v for v in VIEWS if v in plugin.projections):
                yield pytest.param(name, mode, view, id=f"{name}-{mode}-{view}")


@pytest.fixture(scope="module")
def renderers():
    opened = {}
    yield lambda name: opened.setdefault(name, create_renderer(name))
    for r in opened.values():
        r.close()


@pytest.mark.parametrize("name, form, mode, view", list(_cases_closed_forms()))
def test_closed_form(tmp_path, renderers, name, form, mode, view):
    cf = CLOSED_FORMS[form]
    scene = cf.scene(tmp_path, mode, view, name)
    image = renderers(name).render(scene)
    lo, hi, compared = cf.bounds(scene)
    assert compared.mean() > 0.5, "most pixels are compared"
    assert hi[compared][..., 3].max() > 0.1, "the view sees the closed form"
    error = error_outside(image, lo, hi, compared)
    tolerances = PLUGINS[name].tolerances or {}
    declared = tolerances.get((form, mode), tolerances.get(form))
    assert declared is not None, (f"{name} declares no tolerance for the {form} closed form (measured here: "
                                  f"{error:.3g}); add it to its plugin's tolerances")
    assert error <= declared, f"{name}, {form}, {mode}, {view}: {error:.3g} outside the exact bounds"


@pytest.mark.parametrize("name, mode, view", list(_cases_oracle()))
def test_against_its_oracle(renderers, name, mode, view):
    """The phantom under a transfer function opaque at every value (so that MinIP sees something), no
    early termination, the renderer's own defaults otherwise."""
    scene = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20,
                              "image.height": 20, "renderer.name": name, "renderer.compositing": mode,
                              "transfer_function.points": [[0, 0.2, 0.4, 0.9, 0.05], [1, 1.0, 0.8, 0.3, 0.4]],
                              "renderer.ert_threshold": 1.0, **own_filter(name, mode), **VIEWS[view]})
    image = renderers(name).render(scene)
    oracle = PLUGINS[name].oracle_image(scene)
    assert np.abs(oracle[..., 3]).max() > 1e-3, "the oracle sees the phantom"
    assert_close(image, oracle)


def _cases_2d():
    """Every renderer with an oracle that classifies grids with a 2D transfer function, in the modes that
    classify samples along a ray (the others are refused with one)."""
    for name, plugin in PLUGINS.items():
        if plugin.oracle is None or "grid" not in plugin.transfer_function_2d:
            continue
        for mode in (m for m in plugin.choices("compositing") if m in ("emission_absorption", "xray")):
            for view in (v for v in VIEWS if v in plugin.projections):
                yield pytest.param(name, mode, view, id=f"{name}-{mode}-{view}")


@pytest.mark.parametrize("name, mode, view", list(_cases_2d()))
def test_a_2d_transfer_function_against_its_oracle(renderers, name, mode, view):
    """ParaView's boxes over value and gradient magnitude (docs/transfer-functions.md), shaded, on the phantom."""
    boxes = [[0.0, 0.0, 0.3, 4.0, 1.0, 0.3, 0.1, 0.9], [0.15, 1.0, 0.9, 8.0, 0.2, 0.4, 1.0, 0.6]]
    scene = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20,
                              "image.height": 20, "renderer.name": name, "renderer.compositing": mode,
                              "transfer_function.boxes_2d": boxes, "transfer_function.size_2d": [64, 32],
                              "renderer.shading.enabled": mode == "emission_absorption",
                              "renderer.ert_threshold": 1.0, **own_filter(name, mode), **VIEWS[view]})
    registry.check(scene)
    image = renderers(name).render(scene)
    oracle = PLUGINS[name].oracle_image(scene)
    assert np.abs(oracle[..., 3]).max() > 1e-3, "the oracle sees the phantom"
    assert_close(image, oracle)


def test_every_renderer_declares_what_it_renders():
    """What the registry reports about each renderer is consistent: choices among the model's, at least
    one compositing mode, a data kind, a renderer class named as registered."""
    for name, plugin in PLUGINS.items():
        assert plugin.choices("compositing"), name
        assert plugin.data_kinds is None or plugin.data_kinds, name
        assert plugin.renderer_class().name == name


# --- several fields: labels and time, for every renderer that declares them --------------------------------

def _takes(plugin, kind: str) -> bool:
    return plugin.data_kinds is None or kind in plugin.data_kinds


def _label_cases():
    for name, plugin in PLUGINS.items():
        if _takes(plugin, "fields") and "label" in plugin.field_roles and "isosurface" in plugin.choices("compositing"):
            for view in (v for v in VIEWS if v in plugin.projections):
                yield pytest.param(name, view, id=f"{name}-{view}")


@pytest.mark.parametrize("name, view", list(_label_cases()))
def test_labels_show_only_their_table(renderers, name, view):
    """A label map of three labels in blocks (two of them touching, so that an interpolation of the values would
    invent the one between): the unshaded isosurface of a label map shows, at every pixel it hits, exactly one
    colour of its table, never a mixture and never a label the voxels do not hold (float32 rounding of the
    colour only)."""
    labels = np.zeros((10, 12, 14), np.uint8)
    labels[2:8, 2:10, 2:7] = 1
    labels[2:8, 2:10, 7:12] = 3  # touching label 1: linear interpolation of the values would make 2 there
    labels[4:6, 4:8, 4:10] = 5
    rows = [[1, 0.9, 0.1, 0.1, 1.0], [2, 0.1, 0.9, 0.1, 1.0], [3, 0.1, 0.2, 0.9, 1.0], [5, 0.9, 0.9, 0.1, 1.0]]
    scene = load_scene(None, {"image.width": WIDTH, "image.height": HEIGHT, "renderer.name": name,
                              "renderer.compositing": "isosurface", **VIEWS[view]},
                       base={"volume": [{"path": _saved_labels(labels), "role": "label",
                                         "transfer_function": {"labels": rows}}]})
    image = np.asarray(renderers(name).render(scene), np.float64)
    hit = image[..., 3] > 0.5
    assert hit.mean() > 0.1, "the view sees the labels"
    assert np.allclose(image[hit, 3], 1.0, atol=1e-6), "an isosurface is opaque"
    present = np.array([r[1:4] for r in rows if r[0] in (1, 3, 5)])
    nearest = np.abs(image[hit, None, :3] - present[None]).max(axis=2).min(axis=1)
    assert nearest.max() < 1e-5, f"{name}: a colour outside the labels' table ({nearest.max():.3g} from the nearest)"
    assert not np.any(np.abs(image[hit, :3] - [0.1, 0.9, 0.1]).max(axis=1) < 1e-3), "label 2 is not in the data"


_LABEL_DIR = []


def _saved_labels(labels) -> str:
    import tempfile

    if not _LABEL_DIR:
        _LABEL_DIR.append(tempfile.mkdtemp(prefix="conformance-labels-"))
    path = f"{_LABEL_DIR[0]}/labels.npy"
    np.save(path, labels)
    return path


def _time_cases():
    for name, plugin in PLUGINS.items():
        if _takes(plugin, "grid"):
            yield pytest.param(name, id=name)


@pytest.mark.parametrize("name", list(_time_cases()))
def test_a_time_step_renders_as_that_step_alone(renderers, name):
    """Step k of a time series is exactly the 3D volume of that step: bit-identical images (the API's time_axis;
    the readers' volume.time is tested with the files in tests/io and tests/apps)."""
    import dvr_gl

    rng = np.random.default_rng(11)
    series = rng.random((3, 8, 9, 10)).astype(np.float32)
    keys = {"size": (WIDTH, HEIGHT), "renderer": name, "transfer_function": [[0, 0.2, 0.4, 0.9, 0.1],
                                                                             [1, 1.0, 0.8, 0.3, 0.6]]}
    keys.update(own_filter_keywords(name), projection=PLUGINS[name].projections[0],
                compositing=PLUGINS[name].choices("compositing")[0])
    step = dvr_gl.scene_of(series, time_axis=0, time=1, **keys)
    alone = dvr_gl.scene_of(series[1], **keys)
    a, b = renderers(name).render(step), renderers(name).render(alone)
    assert np.array_equal(a, b)
    assert np.asarray(a)[..., 3].max() > 1e-3


def own_filter_keywords(name) -> dict:
    """:func:`closed_forms.own_filter`'s settings as the API's keywords."""
    return {k.removeprefix("renderer."): v for k, v in own_filter(name).items()}
