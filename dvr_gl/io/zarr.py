"""zarr arrays and OME-Zarr images through the zarr package (extra ``zarr``).

* A zarr array of three dimensions (leading axes of size 1 are dropped): ``[z, y, x]``, spacing 1.
* A group holding one array (or the one ``volume.array`` names, by its path in the group).
* An OME-Zarr image (NGFF 0.4, ``multiscales`` in the group's attributes, or 0.5, under ``ome``): the
  level ``volume.level`` chooses (0, the default, is the full resolution); its ``axes`` name the z, y
  and x axes (in any order: the array is transposed by name, never guessed), a time or channel axis of
  size 1 is dropped and a longer one refused; the ``coordinateTransformations``, the dataset's then the
  multiscale's, give the spacing (``scale``) and origin (``translation``) in the axes' units.

The bytes the chosen array holds are checked against the memory budget before it is read.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import SandboxError, check_bytes, current
from .common import RawArray, check_sample_type, check_spacing, require

SPATIAL = ("z", "y", "x")


def read_zarr(path: Path, array: str | None = None, level: int | None = None) -> RawArray:
    target, axes, transforms, name = open_zarr(path, array, level)
    dtype = check_sample_type(np.dtype(target.dtype), name, "dtype", str(target.dtype))
    check_bytes(math.prod(target.shape) * dtype.itemsize, f"{name}: the zarr array of shape {target.shape}",
                "choose a coarser level (volume.level), or raise the memory budget")
    index, order, spacing, origin = zarr_plan(target.shape, axes, transforms, name)
    data = np.asarray(target[...])
    return RawArray(np.ascontiguousarray(np.transpose(data[index], order)), spacing, origin)


def open_zarr(path: Path, array: str | None = None, level: int | None = None, with_levels: bool = False):
    """The zarr array chosen (see the module doc) without reading it: ``(array, axes, transforms, name)``;
    ``axes`` is None for an array without OME metadata.  ``with_levels``: a fifth item, the
    ``(array, transforms)`` of each coarser OME-Zarr level after the chosen one, fine to coarse."""
    zarr = require("zarr", "zarr", "zarr")
    path = Path(path)
    if not current().allows(path):
        raise SandboxError(f"{path}: the zarr store lies outside the allowed folders; move it into one of them")
    name = str(path)
    try:
        node = zarr.open(store=name, mode="r")
    except Exception as exc:  # zarr raises many kinds for a folder that is not a store  # noqa: BLE001
        raise VolumeError(f"{name}: not a zarr store "
                          f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    axes, transforms, coarser = None, [], []
    if isinstance(node, zarr.Array):
        if array is not None or level is not None:
            raise VolumeError(f"{name}: a single zarr array; volume.array and volume.level apply to groups: "
                              f"remove them")
        target = node
    else:
        attrs = dict(node.attrs)
        multiscales = attrs.get("multiscales") or attrs.get("ome", {}).get("multiscales")
        if multiscales:
            target, axes, transforms = _level(node, multiscales[0], level, name)
            chosen = 0 if level is None else int(level)
            coarser = [_level(node, multiscales[0], k, name)[::2]
                       for k in range(chosen + 1, len(multiscales[0].get("datasets") or []))]
        else:
            if level is not None:
                raise VolumeError(f"{name}: volume.level applies to OME-Zarr multiscale images; this group has no "
                                  f"multiscales metadata")
            target = _member(node, array, name)
    return (target, axes, transforms, name, coarser) if with_levels else (target, axes, transforms, name)


def zarr_layout(path: Path, array: str | None = None, level: int | None = None):
    """The chosen array and its coarser levels, unread (:func:`open_zarr` ``with_levels``), for reading in part."""
    return open_zarr(path, array, level, with_levels=True)


def zarr_plan(shape, axes, transforms, name):
    """How to turn an array of ``shape`` into the volume ``[z, y, x]``: ``(index, order, spacing, origin)``:
    ``array[index]`` drops the axes of size 1 that are not spatial, ``np.transpose(_, order)`` orders the
    spatial ones z, y, x; spacing and origin (x first) come from the OME transforms (None without
    ``axes``: a bare array's leading axes of size 1 are dropped, nothing is transposed)."""
    if axes is None:
        drop = 0
        while len(shape) - drop > 3 and shape[drop] == 1:
            drop += 1
        if len(shape) - drop != 3:
            raise VolumeError(f"{name}: the array has shape {tuple(shape)}; a volume needs 3 dimensions (z, y, x)")
        return (0,) * drop + (slice(None),) * 3, (0, 1, 2), None, None
    return _by_axes(shape, axes, transforms, name)
def _member(group, array, name):
    arrays = dict(sorted(group.arrays()))
    if array is not None:
        try:
            found = group[array]
        except KeyError:
            found = None
        if found is None or not hasattr(found, "dtype"):
            raise VolumeError(f"{name}: no array {array!r} in the group; it has "
                              f"{', '.join(map(repr, arrays)) or 'none'}")
        return found
    if len(arrays) != 1:
        raise VolumeError(f"{name}: the group holds {len(arrays)} arrays ({', '.join(map(repr, arrays)) or 'none'}); "
                          f"name one with volume.array")
    return next(iter(arrays.values()))


def _level(group, multiscale, level, name):
    datasets = multiscale.get("datasets") or []
    level = 0 if level is None else int(level)
    if not 0 <= level < len(datasets):
        raise VolumeError(f"{name}: volume.level {level} is out of range; the image has {len(datasets)} levels "
                          f"(0 is the full resolution, {len(datasets) - 1} the coarsest)")
    axes = multiscale.get("axes")
    if not axes:
        raise VolumeError(f"{name}: the multiscales metadata has no axes; fix the store (OME-Zarr 0.4 or later)")
    names = [a["name"] if isinstance(a, dict) else str(a) for a in axes]
    types = [a.get("type") if isinstance(a, dict) else None for a in axes]
    transforms = list(datasets[level].get("coordinateTransformations") or []) + \
        list(multiscale.get("coordinateTransformations") or [])
    return group[datasets[level]["path"]], list(zip(names, types)), transforms


def _by_axes(shape, axes, transforms, name):
    if len(axes) != len(shape):
        raise VolumeError(f"{name}: {len(axes)} axes for an array of {len(shape)} dimensions; fix the metadata")
    names = [n.lower() for n, _ in axes]
    scale, shift = np.ones(len(axes)), np.zeros(len(axes))
    for t in transforms:
        if t.get("type") == "scale":  # applied in turn: a later scale scales an earlier translation too
            factor = np.asarray(t["scale"], dtype=np.float64)
            scale, shift = scale * factor, shift * factor
        elif t.get("type") == "translation":
            shift = shift + np.asarray(t["translation"], dtype=np.float64)
    index = []
    for (axis, kind), size in zip(axes, shape):
        if axis.lower() in SPATIAL:
            index.append(slice(None))
        elif size == 1:
            index.append(0)
        else:
            what = "channel" if kind == "channel" or axis.lower() == "c" else "time" if kind == "time" or \
                axis.lower() == "t" else kind or "other"
            raise VolumeError(f"{name}: the {what} axis {axis!r} has {size} entries; a volume is one scalar field: "
                              f"write one {what} to its own array (e.g. with zarr) and read that")
    missing = [a for a in SPATIAL if a not in names]
    if missing:
        raise VolumeError(f"{name}: the axes {names} name no {', '.join(missing)} axis; a volume needs z, y and x")
    kept = [n for n in names if n in SPATIAL]
    order = tuple(kept.index(a) for a in SPATIAL)  # by name: [z, y, x]
    at = {n: i for i, n in enumerate(names)}
    spacing = check_spacing([scale[at[a]] for a in ("x", "y", "z")], name, "the scale coordinateTransformation")
    origin = tuple(float(shift[at[a]]) for a in ("x", "y", "z"))
    return tuple(index), order, spacing, origin
