"""The shared regular-grid datasets splatted against splatting's same-slabs oracle (from
tests/apps/test_datasets_render.py)."""

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.splatting.oracle import oracle as splatting_reference
from dvr_gl.scene.resolve import load_scene
from rendered_datasets import DATASETS, dataset_id

# Splatting draws every kernel of the grid once per slab it meets: on llvmpipe some 1.3 microseconds a
# kernel and slab, whatever the image size, so the datasets of a few hundred thousand samples are tested
# here and the larger ones (CThead, lobster, brainsmall, hydrogen, MNI152: 3 to 10 million kernels, 16-69 s
# a frame at 24x24, all within 2.7e-5 of the oracle, measured) in `dvr bench splatting --shared`.
SPLATTED = ["regular/bucky.nhdr", "regular/nucleon.nhdr", "regular/neghip.nhdr", "regular/ironProt.nhdr",
            "regular/headsq_quarter.nhdr"]


@pytest.mark.parametrize("name", SPLATTED, ids=dataset_id)
def test_dataset_renders_with_splatting(shared_data, shared_gl_context, shared_volumes, name):
    """Post-classified in perspective, pre-classified in orthographic, against the same-slabs oracle
    (slabs of two voxels: half the draws).  Measured at most 1.5e-5 (headsq: values of 1000 HU, whose
    float32 sums the precision of splatting scales with); asserted as for the other renderers."""
    overrides = {"volume.path": str(shared_data / name), "image.width": 24, "image.height": 24,
                 "renderer.name": "splatting", "renderer.filter": "gaussian", "renderer.slab_width": 2.0,
                 "renderer.ert_threshold": 1.0, **DATASETS[name]}  # the oracle terminates nothing
    with create_renderer("splatting", ctx=shared_gl_context) as splatting:
        for extra in ({"camera.projection": "perspective"},
                      {"camera.projection": "orthographic", "renderer.classification": "pre"}):
            scene = load_scene(None, {**overrides, **extra}).replace(volume=shared_volumes(name))
            image = splatting.render(scene)
            reference = splatting_reference(scene)
            assert np.all(np.isfinite(image)) and image.min() >= 0 and image[..., 3].max() <= 1
            assert reference[..., 3].max() > 0.05, "the preset shows nothing of this dataset"
            assert_close(image, reference)
