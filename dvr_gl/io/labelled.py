"""xarray ``DataArray``s as volumes: the dimension names say which axis is z, y and x, and the coordinates
give the spacing and origin.  xarray itself is never imported: an object is recognised by its type's name
and module, and read through its ``dims``, ``coords``, ``attrs`` and ``transpose``.

* dims ``z``, ``y``, ``x`` (any case, any order: the array is transposed by name, as a view); other
  dims of size 1 are dropped, longer ones refused (choose one with ``.isel``);
* a coordinate along an axis must be evenly spaced (within :data:`UNIFORM`) and increasing: its step
  is the spacing, its first value the origin; without one, spacing 1 and origin 0;
* the name is the array's ``name`` (or its ``long_name`` attribute).
"""

from __future__ import annotations

import numpy as np

from ..errors import VolumeError

UNIFORM = 1e-4  # relative: the steps of a coordinate may differ by this fraction of their mean
AXES = ("x", "y", "z")


def is_data_array(obj) -> bool:
    kind = type(obj)
    return kind.__name__ == "DataArray" and kind.__module__.split(".")[0] == "xarray"


def unpack(da, spacing, origin, name, defaults) -> dict:
    """``data``, ``spacing``, ``origin`` and ``name`` for a Volume from ``da``; the spacing, origin and name
    given to the Volume win where they differ from the defaults (``defaults``: their default values)."""
    label = str(da.name) if da.name is not None else str(da.attrs.get("long_name", name))
    by_name = {str(d).lower(): d for d in da.dims}
    missing = [a for a in ("z", "y", "x") if a not in by_name]
    if missing:
        raise VolumeError(f"{label}: a DataArray with dims {tuple(map(str, da.dims))} names no "
                          f"{', '.join(missing)} axis; rename its dims to z, y, x (da.rename(...)) so that none is "
                          f"guessed")
    for d, size in zip(da.dims, da.shape):
        if str(d).lower() not in AXES:
            if size != 1:
                raise VolumeError(f"{label}: dim {str(d)!r} has {size} entries; a volume is one 3D field: choose "
                                  f"one with da.isel({d}=...)")
            da = da.isel({d: 0})
    da = da.transpose(by_name["z"], by_name["y"], by_name["x"])
    steps, starts = [], []
    for a in AXES:
        step, start = _axis(da, by_name[a], label)
        steps.append(step)
        starts.append(start)
    return {"data": np.asarray(da.data),
            "spacing": spacing if tuple(spacing) != defaults["spacing"] else tuple(steps),
            "origin": origin if tuple(origin) != defaults["origin"] else tuple(starts),
            "name": name if name != defaults["name"] else label}


def _axis(da, dim, label) -> tuple[float, float]:
    if dim not in da.coords:
        return 1.0, 0.0
    try:
        values = np.asarray(da.coords[dim].values, dtype=np.float64)
    except (TypeError, ValueError):
        raise VolumeError(f"{label}: the {dim!r} coordinate is not numeric ({da.coords[dim].dtype}); drop it "
                          f"(da.drop_vars({str(dim)!r})) or give numbers") from None
    if values.size == 1:
        return 1.0, float(values[0])
    steps = np.diff(values)
    mean = float(steps.mean())
    if not np.all(np.isfinite(values)) or mean <= 0:
        raise VolumeError(f"{label}: the {dim!r} coordinate is not increasing; reverse the axis "
                          f"(da.isel({dim}=slice(None, None, -1))) or fix the coordinate")
    worst = float(np.abs(steps - mean).max())
    if worst > UNIFORM * mean:
        i = int(np.argmax(np.abs(steps - mean)))
        raise VolumeError(f"{label}: the {dim!r} coordinate is not evenly spaced (step {steps[i]:.6g} at index {i}, "
                          f"mean {mean:.6g}); a volume is a regular grid: resample it (da.interp) first")
    return mean, float(values[0])
