"""Channels and time steps of a volume file: what a file holds beyond its three space axes, how a reader
says it (:class:`Axes`, :class:`RawChannels`), and the checks of ``volume.channel`` and ``volume.time``
that every reader shares.

A file with channels (OME-Zarr ``c``, an ImageJ or OME hyperstack, NIfTI 4D/5D with a vector intent) read
with no channel chosen gives every channel, each a scalar field (a
:class:`~dvr_gl.fields.layers.FieldSet`, composited per sample); ``volume.channel = k`` gives channel ``k``
alone (a :class:`~dvr_gl.fields.grid.Volume`).  A file with time steps (OME-Zarr ``t``, a hyperstack's
frames, NIfTI 4D, a glob of 3D files) gives step ``volume.time`` (0 first, the default), and only that
step's voxels are read.  A file without time is a series of one step: ``time = 0`` reads it, a later step
is refused.  Channel ``k`` is named by the file where it names its channels (OME ``Channel Name``, the
omero ``label``), else ``"channel k"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..errors import VolumeError
from .common import RawArray

#: The most channels or time steps a header may promise: a count beyond is a damaged header (a series of
#: a million steps is read one step at a time, but its count is still believed before anything is read).
MAX_COUNT = 1 << 20
#: Seconds per unit of the time units headers write (OME-Zarr's UDUNITS names, OME's symbols, NIfTI's).
SECONDS = {"s": 1.0, "second": 1.0, "sec": 1.0, "ms": 1e-3, "millisecond": 1e-3, "msec": 1e-3,
           "us": 1e-6, "µs": 1e-6, "microsecond": 1e-6, "usec": 1e-6, "ns": 1e-9, "nanosecond": 1e-9,
           "min": 60.0, "minute": 60.0, "h": 3600.0, "hour": 3600.0, "d": 86400.0, "day": 86400.0}


@dataclass(frozen=True)
class Axes:
    """What a file holds beyond its space axes: ``channels`` (0: no channel axis; 1 or more: an axis of
    that many), their ``names`` (empty: unnamed), ``steps`` (1 for a file without time) and ``interval``,
    the seconds between steps (None: not stated)."""

    channels: int = 0
    names: tuple = ()
    steps: int = 1
    interval: float | None = None


@dataclass
class RawChannels:
    """A reader's result when every channel is read: one :class:`RawArray` per channel (one grid) and each
    channel's name (``"channel k"`` where the file names none)."""

    arrays: list[RawArray]
    names: list[str] = field(default_factory=list)


def check_count(value, name: str, what: str) -> int:
    """A count of channels or steps a header states: an integer in ``[1, MAX_COUNT]``, else one line."""
    try:
        count = int(value)
        exact = count == value if not isinstance(value, str) else True
    except (TypeError, ValueError, OverflowError):
        count, exact = -1, False
    if not exact or not 1 <= count <= MAX_COUNT:
        raise VolumeError(f"{name}: its header gives {value!r} {what}; a count is an integer from 1 to {MAX_COUNT}: "
                          f"fix the header")
    return count


def pick_channel(channel, axes: Axes, name: str) -> int | None:
    """The channel to read (None: every channel), or one line: a channel on a file without channels, or
    past the last."""
    if channel is None:
        return None
    if axes.channels == 0:
        raise VolumeError(f"{name}: volume.channel = {channel}: this file has no channels; remove it")
    if not 0 <= int(channel) < axes.channels:
        raise VolumeError(f"{name}: volume.channel = {channel} is past the last channel; the file has "
                          f"{axes.channels} (0 to {axes.channels - 1})")
    return int(channel)


def pick_step(time, axes: Axes, name: str) -> int:
    """The time step to read (default 0), or one line naming how many the file has."""
    step = 0 if time is None else int(time)
    if not 0 <= step < axes.steps:
        has = f"{axes.steps} time steps (0 to {axes.steps - 1})" if axes.steps > 1 else "one time step (0)"
        raise VolumeError(f"{name}: volume.time = {time} is past the end; the file has {has}")
    return step


def channel_names(names, count: int) -> list[str]:
    """Each channel's name: the file's where it gives one (a non-empty string), else ``"channel k"``."""
    names = list(names or ())
    return [str(names[k]).strip() if k < len(names) and str(names[k] or "").strip() else f"channel {k}"
            for k in range(count)]


def seconds(value, unit) -> float | None:
    """An interval in seconds from a header's value and time unit; None where either is missing, unknown,
    not finite or not positive."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return None
    factor = SECONDS.get(str(unit).strip().lower() if unit is not None else "s")
    if factor is None or not math.isfinite(value) or value <= 0:
        return None
    return value * factor
