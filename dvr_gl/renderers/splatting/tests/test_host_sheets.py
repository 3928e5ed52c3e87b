"""Image-aligned post-classified sheets rasterized on the host (:mod:`dvr_gl.renderers.splatting.host`, numba)
against the same-slabs oracle, the GL path and the same loops uncompiled."""

import numpy as np
import pytest

from conftest import assert_close, small_scene
from dvr_gl.renderers.splatting import host
from dvr_gl.renderers.splatting.oracle import oracle as same_slabs
from dvr_gl.renderers.splatting.tests.conftest import OPAQUE_TF

pytest.importorskip("numba")

GAUSSIAN = {"renderer.name": "splatting", "renderer.filter": "gaussian"}


def scene_of(extra=None, size=16, image=24):
    return small_scene({**GAUSSIAN, **OPAQUE_TF, "volume.size": size, "image.width": image, "image.height": image,
                        "renderer.ert_threshold": 1.0, **(extra or {})})


@pytest.mark.parametrize("extra", [{}, {"camera.projection": "orthographic", "camera.azimuth": 70.0}],
                         ids=["perspective", "orthographic"])
def test_host_sheets_match_the_oracle_and_gl(splatting, extra):
    """Float64 loops with the closed-form erf: measured within 7e-8 of the oracle (the footprint table's
    interpolation; GL's float32: 2.5e-7), asserted 1e-6; the GL path still within conftest's float32
    assertion of the oracle, and of the host's image."""
    scene = scene_of(extra)
    assert host.serves(scene)
    oracle = same_slabs(scene)
    assert oracle[..., 3].max() > 0.3
    image = splatting.render(scene)
    assert np.abs(image - oracle).max() < 1e-6
    splatting.host_sheets = False
    try:
        drawn = splatting.render(scene)
    finally:
        splatting.host_sheets = True
    assert_close(drawn, oracle)
    assert_close(drawn, image.astype(np.float64))


def test_host_sheets_terminate_early_as_gl_does(splatting):
    """Early termination per pixel (after each group of slabs): every pixel within 1 - threshold of the
    unterminated image, as GL's (per slab)."""
    scene = scene_of({"renderer.ert_threshold": 0.9, "volume.size": 24})
    full = splatting.render(scene.with_renderer(ert_threshold=1.0))
    assert full[..., 3].max() > 0.95
    terminated = splatting.render(scene)
    assert np.abs(terminated - full).max() <= 0.1 + 1e-6


def test_compiled_loops_equal_the_uncompiled_ones():
    """The numba loops and the same Python functions uncompiled give the same image (to float64 rounding)."""
    from dvr_gl.renderers.splatting import host_compiled
    from dvr_gl.renderers.splatting.sheets import kernel_reach
    from dvr_gl.renderers.splatting.splats import Splats

    class Uncompiled:
        fill_sheets = staticmethod(host_compiled.fill_sheets.py_func)
        composite_sheets = staticmethod(host_compiled.composite_sheets.py_func)

    scene = scene_of({"volume.size": 6, "image.width": 8, "image.height": 8})
    lo, hi = (np.asarray(b, float) for b in scene.field.bounds)
    centre = 0.5 * (lo + hi)
    splats = Splats(scene.field, kernel_reach(scene), centre)
    table = scene.transfer_function.tabulate(scene.renderer.lut_size)
    compiled, _ = host.render(scene, splats, centre, table)
    uncompiled, _ = host.render(scene, splats, centre, table, loops=Uncompiled)
    assert compiled[..., 3].max() > 0.1
    np.testing.assert_allclose(compiled, uncompiled, rtol=0, atol=1e-7)


def test_other_frames_stay_in_gl():
    """What the host path does not serve: pre-classification, other sheet buffers and compositing, shading,
    the cubic B-spline, EWA's footprints and its low-pass."""
    for extra in ({"renderer.classification": "pre"}, {"renderer.sheet_buffer": "axis_aligned"},
                  {"renderer.compositing": "xray"}, {"renderer.filter": "cubic_bspline"},
                  {"renderer.footprint": "ewa"}, {"renderer.screen_low_pass": 1.0},
                  {"renderer.shading.enabled": True}):
        assert not host.serves(scene_of(extra)), extra
