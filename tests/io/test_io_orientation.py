"""Orientation from the headers that state it (NRRD, NIfTI, MetaImage), in the patient's LPS frame.

Every test writes a header with a known index-to-patient map and checks that the volume places a few
samples where the header says, ``origin + D @ (i*sx, j*sy, k*sz)``, with the voxels in the order written.
"""

import math

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import load_volume

DATA = np.arange(4 * 3 * 2, dtype=np.int16).reshape(2, 3, 4)  # [z, y, x]: nx=4 ny=3 nz=2
RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])
C, S = math.cos(math.radians(30)), math.sin(math.radians(30))

# index-axis steps (rows: x, y, z axis) in the header's own frame
PERMUTED = [[0, 2, 0], [-1.5, 0, 0], [0, 0, 3]]
FLIPPED = [[-1, 0, 0], [0, 1, 0], [0, 0, 2]]  # det -1: x stored mirrored
OBLIQUE = [[C * 0.5, S * 0.5, 0], [-S, C, 0], [0, 0, 2]]  # turned 30 degrees about z
SHEARED = [[1, 0, 0], [0.2, 1, 0], [0, 0, 1]]


def placed(v, index):
    """Patient position of sample ``index = (i, j, k)`` as the volume states it."""
    return np.asarray(v.origin) + np.asarray(v.direction) @ (np.asarray(index) * np.asarray(v.spacing))


def expected(steps, origin, index, to_lps):
    return to_lps @ (np.asarray(origin, float) + np.asarray(index) @ np.asarray(steps, float))


INDICES = [(0, 0, 0), (3, 0, 0), (0, 2, 0), (0, 0, 1), (3, 2, 1)]


def check_placement(v, steps, origin, to_lps):
    np.testing.assert_array_equal(v.data, DATA)  # voxels never reordered
    for index in INDICES:
        np.testing.assert_allclose(placed(v, index), expected(steps, origin, index, to_lps), atol=1e-9)


# --- NRRD -------------------------------------------------------------------------------------------

def write_nrrd(tmp_path, steps, origin=(10, 20, 30), space="right-anterior-superior"):
    vectors = " ".join("(" + ",".join(repr(float(c)) for c in s) + ")" for s in steps)
    path = tmp_path / "v.nrrd"
    path.write_bytes((f"NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
                      f"space: {space}\nspace directions: {vectors}\n"
                      f"space origin: ({','.join(map(str, origin))})\n\n").encode() + DATA.astype("<i2").tobytes())
    return path


SPACE_SIGNS = {"right-anterior-superior": RAS_TO_LPS, "RAS": RAS_TO_LPS, "left-posterior-superior": np.eye(3),
               "left-anterior-superior": np.diag([1.0, -1.0, 1.0]), "3D-right-handed": np.eye(3)}


@pytest.mark.parametrize("space", sorted(SPACE_SIGNS))
@pytest.mark.parametrize("steps", [PERMUTED, FLIPPED, OBLIQUE], ids=["permuted", "flipped", "oblique"])
def test_nrrd_space_directions_in_lps(tmp_path, space, steps):
    pytest.importorskip("nrrd")
    v = load_volume(write_nrrd(tmp_path, steps, space=space))
    check_placement(v, steps, (10, 20, 30), SPACE_SIGNS[space])
    np.testing.assert_allclose(v.spacing, np.linalg.norm(steps, axis=1))


def test_nrrd_ras_letters(tmp_path):
    """RAS identity steps: the x axis points to the patient's right, y to anterior (LPS -x, -y)."""
    pytest.importorskip("nrrd")
    from dvr_gl.orientation import axis_letters

    v = load_volume(write_nrrd(tmp_path, np.eye(3)))
    assert axis_letters(v.direction) == "RAS" and v.origin == (-10.0, -20.0, 30.0)
    assert axis_letters(load_volume(write_nrrd(tmp_path, OBLIQUE, space="LPS")).direction) == "lpS"


def test_nrrd_sheared_axes_are_refused(tmp_path):
    pytest.importorskip("nrrd")
    with pytest.raises(VolumeError, match=r"space directions gives index axes .* degrees from orthogonal"):
        load_volume(write_nrrd(tmp_path, SHEARED))


@pytest.mark.parametrize("space, message", [("right-anterior-superior-time", "not a 3D NRRD space"),
                                            ("up-down-sideways", "not a 3D NRRD space")])
def test_nrrd_unknown_space_is_refused(tmp_path, space, message):
    pytest.importorskip("nrrd")
    with pytest.raises(VolumeError, match=message):
        load_volume(write_nrrd(tmp_path, np.eye(3), space=space))


# --- NIfTI ------------------------------------------------------------------------------------------

def write_nifti(tmp_path, sform=None, qform=None, name="v.nii"):
    nib = pytest.importorskip("nibabel")
    img = nib.Nifti1Image(DATA.transpose(2, 1, 0), None)
    img.set_sform(sform if sform is not None else np.eye(4), code=0 if sform is None else 2)
    img.set_qform(qform if qform is not None else np.eye(4), code=0 if qform is None else 1)
    nib.save(img, str(tmp_path / name))
    return tmp_path / name


def affine(steps, origin):
    a = np.eye(4)
    a[:3, :3] = np.asarray(steps, float).T
    a[:3, 3] = origin
    return a


@pytest.mark.parametrize("steps", [PERMUTED, FLIPPED, OBLIQUE], ids=["permuted", "flipped", "oblique"])
def test_nifti_sform_wins_over_qform(tmp_path, steps):
    v = load_volume(write_nifti(tmp_path, sform=affine(steps, (5, -6, 7)), qform=affine(np.eye(3), (1, 1, 1))))
    check_placement(v, steps, (5, -6, 7), RAS_TO_LPS)


@pytest.mark.parametrize("steps", [FLIPPED, OBLIQUE], ids=["flipped", "oblique"])
def test_nifti_qform_when_sform_code_is_zero(tmp_path, steps):
    v = load_volume(write_nifti(tmp_path, qform=affine(steps, (5, -6, 7))))
    check_placement(v, steps, (5, -6, 7), RAS_TO_LPS)


def test_nifti_without_orientation_is_identity(tmp_path):
    """Both codes 0 (NIfTI's method 1): pixdim only, no orientation stated."""
    v = load_volume(write_nifti(tmp_path))
    assert v.origin == (0.0, 0.0, 0.0) and v.direction == ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def test_nifti_sheared_sform_is_refused(tmp_path):
    with pytest.raises(VolumeError, match=r"sform .* degrees from orthogonal"):
        load_volume(write_nifti(tmp_path, sform=affine(SHEARED, (0, 0, 0))))


def test_mni152_template_is_ras(shared_data):
    """The MNI152 2009 template's sform (code 4, MNI space) is RAS with 1 mm voxels and its origin at
    (-96, -132, -78) mm RAS: (96, 132, -78) in LPS."""
    pytest.importorskip("nibabel")
    from dvr_gl.orientation import axis_letters

    v = load_volume(shared_data / "regular/MNI152_2009_template.nii.gz")
    assert axis_letters(v.direction) == "RAS"
    assert v.spacing == (1.0, 1.0, 1.0) and v.origin == (96.0, 132.0, -78.0)


# --- MetaImage ---------------------------------------------------------------------------------------

def write_mhd(tmp_path, steps, origin=(1, 2, 3), key="TransformMatrix"):
    steps = np.asarray(steps, float)
    spacing = np.linalg.norm(steps, axis=1)
    numbers = " ".join(repr(float(x)) for x in (steps / spacing[:, None]).ravel())  # axis by axis, as ITK
    (tmp_path / "v.raw").write_bytes(DATA.astype("<i2").tobytes())
    (tmp_path / "v.mhd").write_text(
        f"ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
        f"{key} = {numbers}\nOffset = {' '.join(map(str, origin))}\n"
        f"ElementSpacing = {' '.join(map(repr, spacing.tolist()))}\nDimSize = 4 3 2\nElementType = MET_SHORT\n"
        f"ElementDataFile = v.raw\n")
    return tmp_path / "v.mhd"


@pytest.mark.parametrize("steps", [PERMUTED, FLIPPED, OBLIQUE], ids=["permuted", "flipped", "oblique"])
def test_metaimage_transform_matrix_is_lps_axis_by_axis(tmp_path, steps):
    check_placement(load_volume(write_mhd(tmp_path, steps)), steps, (1, 2, 3), np.eye(3))


def test_metaimage_matrix_order(tmp_path):
    """The first three numbers are the x index axis (ITK's order): ``0 1 0 -1 0 0 0 0 1`` puts x toward
    posterior and y toward the patient's right."""
    from dvr_gl.orientation import axis_letters

    assert axis_letters(load_volume(write_mhd(tmp_path, [[0, 1, 0], [-1, 0, 0], [0, 0, 1]])).direction) == "PRS"
    assert axis_letters(load_volume(write_mhd(tmp_path, FLIPPED, key="Rotation")).direction) == "RPS"


def test_metaimage_sheared_matrix_is_refused(tmp_path):
    with pytest.raises(VolumeError, match="TransformMatrix gives index axes"):
        load_volume(write_mhd(tmp_path, SHEARED))


def test_frogtissue_is_identity(shared_data):
    v = load_volume(shared_data / "large/frogtissue.mhd")
    assert v.direction == ((1, 0, 0), (0, 1, 0), (0, 0, 1)) and v.origin == (0.0, 0.0, 0.0)
    assert v.spacing == (1.0, 1.0, 1.5)
