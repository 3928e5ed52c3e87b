"""3D texture slicing (view-aligned slices at the sample distance) against the reference that samples the
same planes, and its behaviour (the checks every slicer passes: tests/slice_checks.py)."""

import numpy as np
import pytest

import slice_checks as checks
from conftest import assert_close, small_scene
from dvr_gl.reference.converged import ConvergedReference


@pytest.fixture(scope="module")
def slicer(shared_gl_context):
    renderer = checks.slicer_on(shared_gl_context, "slicing3d")
    yield renderer
    renderer.close()


@pytest.fixture(autouse=True)
def current_context(gl_context):
    """The session's context current for every test (a renderer released elsewhere leaves none)."""
    return gl_context


@pytest.mark.parametrize("extra", checks.VARIANTS, ids=checks.VARIANT_IDS)
def test_slicing3d_matches_the_same_plane_reference(slicer, extra):
    checks.matches_the_same_plane_reference(slicer, extra)


@pytest.mark.parametrize("extra, message", checks.REFUSALS)
def test_slicing3d_refuses_other_compositing_and_jitter(slicer, extra, message):
    checks.refuses(slicer, extra, message)


@pytest.mark.parametrize("extra", list(checks.BRICKED.values()), ids=list(checks.BRICKED))
def test_slicing3d_bricked_equals_unbricked(slicer, extra):
    checks.bricked_equals_unbricked(slicer, extra)


def test_slicing3d_one_voxel_thick_volume(tmp_path, slicer):
    checks.one_voxel_thick_volume(tmp_path, slicer)


@pytest.mark.parametrize("extra", [{"renderer.filter": "cubic_bspline"}, {"renderer.filter": "catmull_rom"},
                                   {"renderer.classification": "pre"},
                                   {"renderer.shading.enabled": True, "renderer.gradient": "texture"}],
                         ids=["bspline", "catmull-rom", "pre", "gradient-texture"])
def test_slicing3d_with_every_filter_and_classification(slicer, extra):
    scene = small_scene({**checks.NO_ERT, **extra})
    assert_close(slicer.render(scene), checks.same_planes(scene, "slicing3d"))


def test_slice_spacing_converges_to_the_converged_reference(slicer):
    """More slices, smaller error: 3D slicing approaches the converged integral (second order)."""
    no_ert = checks.NO_ERT
    converged = ConvergedReference(small_scene({**no_ert, "renderer.converged_tolerance": 1e-6})).render_float64()
    errors = []
    for d in (1.0, 0.5, 0.25):
        image = slicer.render(small_scene({**no_ert, "renderer.sample_distance_voxels": d}))
        errors.append(np.sqrt(np.mean((image - converged) ** 2)))
    assert errors[0] > 2.5 * errors[1] > 6 * errors[2]
