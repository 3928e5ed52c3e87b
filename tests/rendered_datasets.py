"""The shared regular-grid datasets every grid renderer is tested on (``../shared/data``), with the
scene overrides that show something of each, and how a judge is called on them.

Used by ``tests/apps/test_datasets_render.py`` (the renderers that brick a grid, by trait) and by the
renderers' own ``test_datasets_NAME.py``.  The volumes are loaded by the ``shared_volumes`` fixture
(conftest.py), one at a time (the CT bunny is large).
"""

from __future__ import annotations

from dvr_gl.orientation import volume_frame_scene

#: CT values in Hounsfield units (stored as HU + 1024) and the bone preset
HU = {"transfer_function.preset": "ct-bone-ivory", "transfer_function.rescale_intercept": -1024.0}
#: dataset file under the shared data folder -> scene overrides
DATASETS = {
    "regular/cthead.nhdr": HU, "regular/hydrogen_atom.nhdr": {}, "regular/neghip.nhdr": {},
    "regular/lobster.nhdr": {}, "regular/bucky.nhdr": {}, "regular/nucleon.nhdr": {}, "regular/ironProt.nhdr": {},
    "regular/brainsmall.nhdr": {}, "regular/headsq_quarter.nhdr": HU,
    "regular/MNI152_2009_template.nii.gz": {}, "large/frogtissue.mhd": {},
    "large/bunny_ct.nhdr": {**HU, "renderer.texture_budget_mb": 48.0},
}


def dataset_id(name: str) -> str:
    """``regular/cthead.nhdr`` -> ``cthead`` (a test id)."""
    return name.split("/")[1].split(".")[0]


def judged(reference, scene, *args, **kwargs):
    """A judge called directly, with the camera in the volume's own frame as Renderer.render gives it to the
    renderers (MNI152's sform is RAS: a mirrored view, flipped back; dvr_gl.orientation)."""
    local, mirrored = volume_frame_scene(scene)
    image = reference(local, *args, **kwargs)
    return image[:, ::-1] if mirrored else image
