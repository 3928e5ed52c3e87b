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

from closed_forms import CLOSED_FORMS, VIEWS, error_outside, own_filter
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


def test_every_renderer_declares_what_it_renders():
    """What the registry reports about each renderer is consistent: choices among the model's, at least
    one compositing mode, a data kind, a renderer class named as registered."""
    for name, plugin in PLUGINS.items():
        assert plugin.choices("compositing"), name
        assert plugin.data_kinds is None or plugin.data_kinds, name
        assert plugin.renderer_class().name == name
