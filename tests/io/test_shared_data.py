"""Every regular-grid dataset in ../shared/data loads with the dims, type, spacing and value
range its README states (skipped, with the reason, when the folder is absent)."""

import numpy as np
import pytest

from dvr_gl.io import load_volume

# file, dims (x, y, z), dtype, spacing, (min, max), mean, as listed in shared/data/README.md.
# The mean (to the README's printed digits) catches garbage voxels that min/max would not.
DATASETS = [
    ("regular/cthead.nhdr", (256, 256, 113), np.int16, (1, 1, 2), (0, 3272), 379.54),
    ("regular/hydrogen_atom.nhdr", (128, 128, 128), np.uint8, (1, 1, 1), (0, 250), 2.857),
    ("regular/neghip.nhdr", (66, 66, 66), np.uint8, (1, 1, 1), (0, 255), 16.780),
    ("regular/lobster.nhdr", (301, 324, 56), np.uint8, (1, 1, 1.4), (0, 255), 13.053),
    ("regular/bucky.nhdr", (32, 32, 32), np.uint8, (1, 1, 1), (0, 255), 35.850),
    ("regular/nucleon.nhdr", (41, 41, 41), np.uint8, (1, 1, 1), (0, 249), 39.398),
    ("regular/ironProt.nhdr", (68, 68, 68), np.uint8, (1, 1, 1), (0, 255), 13.138),
    ("regular/ironProt.vtk", (68, 68, 68), np.uint8, (1, 1, 1), (0, 255), 13.138),
    ("regular/brainsmall.nhdr", (128, 128, 84), np.uint8, (1, 1, 1), (0, 202), 14.012),
    ("regular/headsq_quarter.nhdr", (64, 64, 93), np.uint16, (3.2, 3.2, 1.5), (0, 3926), 507.69),
    ("regular/MNI152_2009_template.nii.gz", (193, 229, 193), np.int16, (1, 1, 1), (0, 1570), 167.10),
    ("large/frogtissue.mhd", (500, 470, 136), np.uint8, (1, 1, 1.5), (0, 29), 0.384),
    pytest.param("large/bunny_ct.nhdr", (512, 512, 361), np.int16, (0.337891, 0.337891, 0.5), (-2000, 4095),
                 -281.24, marks=pytest.mark.slow, id="large/bunny_ct.nhdr (two bzip2 parts)"),
]


@pytest.mark.parametrize("name, dims, dtype, spacing, value_range, mean", DATASETS,
                         ids=[None if hasattr(d, "marks") else d[0] for d in DATASETS])
def test_dataset_loads(shared_data, name, dims, dtype, spacing, value_range, mean):
    v = load_volume(shared_data / name)
    assert v.dims == dims
    assert v.data.dtype == dtype
    np.testing.assert_allclose(v.spacing, spacing)
    assert v.value_range == value_range
    digits = len(str(mean).split(".")[1])
    assert round(float(v.data.mean(dtype=np.float64)), digits) == pytest.approx(mean, abs=10 ** -digits)


def test_vtk_and_raw_copies_of_iron_protein_agree(shared_data):
    a = load_volume(shared_data / "regular/ironProt.vtk")
    b = load_volume(shared_data / "regular/ironProt.nhdr")
    np.testing.assert_array_equal(a.data, b.data)


def test_every_regular_file_is_covered(shared_data):
    """A dataset added to the shared folder must be added here too."""
    listed = {d.values[0] if hasattr(d, "marks") else d[0] for d in DATASETS}
    headers = {f"regular/{p.name}" for p in (shared_data / "regular").iterdir()
               if p.suffix in (".nhdr", ".vtk") or p.name.endswith(".nii.gz")}
    headers |= {f"large/{p.name}" for p in (shared_data / "large").iterdir() if p.suffix in (".nhdr", ".mhd")}
    assert headers <= listed
