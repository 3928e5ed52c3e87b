"""The README's Python quick start, run as written on the shared CT (CThead: stored as HU + 1024, its
slices from the top of the head down, no orientation in its header): the head stands upright and only
bone is drawn in bone colours.

Upright: the skull is widest at the cranium, so the widest row of the opaque picture lies above the
middle of its rows (measured: row 117 against the middle 130; upside down, without ``up``: 132 against
121). Bone only: without ``rescale_intercept`` the skin (1000 in the file's values) reads as bone and
43 % of the picture is opaque, in reddish colours (sRGB green over red 0.47); with it, 15 % (measured;
asserted under 25 %), bone-coloured (0.74; asserted above 0.6).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from conftest import REPO

#: the quick start as the README shows it (its first lines: the rest of that block names data one has)
QUICK_START = '''\
import dvr_gl

ct = dvr_gl.load_volume("../shared/data/regular/cthead.nhdr")   # any format dvr info lists
image = dvr_gl.render(ct, transfer_function="CT-Bone",          # 3D Slicer's preset, in Hounsfield units
                      rescale_intercept=-1024,                  # this file stores HU + 1024
                      up=(0, 0, -1),                            # its slices run from the top of the head down
                      azimuth=30, elevation=20, size=(256, 256))
image                                     # shows itself inline in Jupyter
image.save("ct.png")                      # .png (8-bit sRGB), .exr/.tif (linear float)
rgba = image.rgba                         # premultiplied linear float32 (H, W, 4)
srgb = image.srgb8()                      # 8-bit sRGB over the background (H, W, 4)
'''

SHARED = REPO.parent / "shared"


def test_the_readme_shows_this_quick_start():
    assert QUICK_START in (REPO / "README.md").read_text(encoding="utf-8")


def test_the_quick_start_draws_the_ct_upright_in_bone_colours(tmp_path):
    if not (SHARED / "data" / "regular" / "cthead.nhdr").exists():
        pytest.skip("the shared datasets are not beside the repository")
    (tmp_path / "shared").symlink_to(SHARED)
    (tmp_path / "repo").mkdir()
    here = os.getcwd()
    os.chdir(tmp_path / "repo")   # the README's relative path, and its ct.png, as from a checkout
    try:
        names: dict = {}
        exec(QUICK_START, names)
    finally:
        os.chdir(here)
    rgba = names["rgba"]
    opaque = rgba[..., 3] > 0.5
    assert (tmp_path / "repo" / "ct.png").exists() and 0.03 < opaque.mean() < 0.25
    rows = np.flatnonzero(opaque.any(axis=1))
    widest = int(np.argmax(opaque.sum(axis=1)))
    assert widest < 0.5 * (rows[0] + rows[-1])   # image row 0 is the top
    red, green = (names["srgb"][..., c][opaque].astype(float).mean() for c in (0, 1))
    assert green / red > 0.6
