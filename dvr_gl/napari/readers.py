"""napari readers for the formats napari lacks, through dvr-gl's own readers (docs/napari.md).

Volumes (NRRD ``.nrrd``/``.nhdr``, MetaImage ``.mhd``/``.mha``, VTK ``.vti`` and legacy ``.vtk``
STRUCTURED_POINTS, NIfTI with the extra ``nifti``, a DICOM series folder or ``.dcm`` files with the extra
``dicom``) become image layers: the array ``[z, y, x]`` as read, ``scale`` the spacing and ``translate`` the
origin, both reversed to napari's (z, y, x); a file that states an orientation (a direction matrix other than
the identity) gets ``affine`` instead of ``translate``: the direction (reversed) and the origin, so that napari
places every voxel where dvr-gl does (``origin + direction @ (index * spacing)``).  A file of several channels
becomes one image layer per channel.  Meshes (``.vtu``, legacy ``.vtk`` UNSTRUCTURED_GRID) become a surface
layer of their boundary triangles with the point scalars (zeros where the scalars are per cell), and
triangle meshes (``.obj``, ``.ply``, ``.stl``: :func:`dvr_gl.geometry.read_mesh`) a surface layer.  A file
dvr-gl cannot read raises the reader's one-line error (napari shows it).  A colour volume (NRRD RGB-color,
RGB TIFF, NIfTI RGB24) becomes an RGB image layer, its colour encoded back to sRGB for napari's display.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..fields.grid import IDENTITY
from ..fields.layers import FieldSet
from ..geometry import read_mesh
from ..io import load_field
from ..presets.colour import linear_to_srgb

VOLUME_SUFFIXES = (".nrrd", ".nhdr", ".mhd", ".mha", ".vti", ".vtk", ".vtu", ".nii", ".nii.gz", ".dcm")
TRIANGLE_SUFFIXES = (".obj", ".ply", ".stl")


def _suffix(path) -> str:
    name = str(path).lower()
    return ".nii.gz" if name.endswith(".nii.gz") else Path(name).suffix


def get_reader(path):
    """napari's reader hook: the reader of ``path`` (a file, a DICOM folder, or a list of DICOM files), or
    None where it is not a format this plugin reads."""
    if isinstance(path, (list, tuple)):
        return read if path and all(_suffix(p) == ".dcm" for p in path) else None
    if os.path.isdir(path):
        return read if any(_suffix(p) == ".dcm" or "." not in p.name for p in Path(path).iterdir()) else None
    return read if _suffix(path) in VOLUME_SUFFIXES + TRIANGLE_SUFFIXES else None


def read(path) -> list[tuple]:
    """napari layer data ``[(data, attributes, layer type), ...]`` of the file (see the module doc)."""
    if not isinstance(path, (list, tuple)) and _suffix(path) in TRIANGLE_SUFFIXES:
        mesh = read_mesh(path)
        return [((mesh.vertices[:, ::-1].copy(), mesh.triangles.copy()), {"name": mesh.name}, "surface")]
    field = load_field(list(path) if isinstance(path, (list, tuple)) else path)
    if isinstance(field, FieldSet):
        return [volume_layer(m.field, m.name or m.field.name) for m in field.members]
    if getattr(field, "kind", None) == "grid":
        return [volume_layer(field, field.name)]
    if getattr(field, "kind", None) == "mesh":
        return [mesh_layer(field)]
    raise VolumeError(f"{path}: a {getattr(field, 'kind', type(field).__name__)} field; napari shows grids and meshes "
                     f"from this reader (particles: use dvr-gl's own renderers)")


def volume_layer(volume, name: str) -> tuple:
    """An image layer's data: the voxels ``[z, y, x]`` with napari's scale, translate or affine (module doc)."""
    attributes = {"name": name, "scale": tuple(volume.spacing[::-1])}
    direction = np.asarray(volume.direction, dtype=np.float64)
    if np.allclose(direction, IDENTITY):
        attributes["translate"] = tuple(volume.origin[::-1])
    else:
        affine = np.eye(4)
        affine[:3, :3] = direction[::-1, ::-1]
        affine[:3, 3] = np.asarray(volume.origin)[::-1]
        attributes["affine"] = affine
    if getattr(volume, "role", None) == "rgb":
        # a colour volume (z, y, x, 4) of linear colour and its opacity source: napari shows RGB values as
        # they are, so its colour goes back to sRGB, without the fourth component (luminance or alpha)
        attributes["rgb"] = True
        return linear_to_srgb(np.asarray(volume.data)[..., :3]).astype(np.float32), attributes, "image"
    return np.asarray(volume.data), attributes, "image"


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """The faces ``(F, 3)`` of a tetrahedral mesh that belong to one cell only: its boundary."""
    faces = np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]])
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    return faces[first[counts == 1]]


def mesh_layer(mesh) -> tuple:
    """A surface layer's data: the boundary of a tetrahedral mesh, vertices (z, y, x), its point scalars."""
    values = mesh.values if mesh.association == "point" else np.zeros(len(mesh.points))
    data = (mesh.points[:, ::-1].copy(), boundary_triangles(mesh.tets), np.asarray(values, dtype=np.float32))
    return data, {"name": mesh.name}, "surface"
