"""A time series (a fourth axis of time): :class:`TimeSeries`, steps read one at a time.

A reader of a file with a time axis (OME-Zarr ``t``, an ImageJ hyperstack's frames, NIfTI 4D, a glob of
files) returns one; the scene's ``volume.time`` picks the step it renders (default 0), and ``dvr render
--frames N --animate time`` and the viewer walk the steps.  Step ``k`` is exactly the field the file holds
at that time, as if it were alone: the scene of step ``k`` renders bit-identical to that 3D volume.

Only the step asked for is read (``read_step``), so a series larger than memory plays within the memory
budget as long as one step fits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from ..errors import SceneError


@dataclass(frozen=True, eq=False)
class TimeSeries:
    """Steps of one field over time.

    name: for messages.
    steps: how many.
    read_step: ``read_step(k) -> field`` (a :class:`~dvr_gl.fields.grid.Volume` or a
        :class:`~dvr_gl.fields.layers.FieldSet` of channels), reading only step ``k``.
    interval: seconds between steps, where the file says (None otherwise).
    """

    name: str
    steps: int
    read_step: Callable[[int], object]
    interval: Optional[float] = None

    kind = "series"

    def step(self, k: int):
        """The field at step ``k`` (0 first), read now."""
        if not isinstance(k, int) or isinstance(k, bool) or not 0 <= k < self.steps:
            raise SceneError(f"volume.time = {k!r}: {self.name} has {self.steps} time step"
                             f"{'s' * (self.steps != 1)} (0 to {self.steps - 1}): choose one of them")
        return self.read_step(k)

    def describe(self) -> str:
        every = f", every {self.interval:g} s" if self.interval else ""
        return f"{self.name}: {self.steps} time steps{every}"


def from_array(data, time_axis: int, name: str = "array", make=None) -> TimeSeries:
    """A series of the steps of array ``data`` along ``time_axis``; ``make(array, k)`` turns a step's array into
    its field (default: the array itself)."""
    import numpy as np

    if not -data.ndim <= time_axis < data.ndim:
        raise SceneError(f"time_axis = {time_axis}: the data has {data.ndim} axes")
    axis = time_axis % data.ndim

    def read(k):
        step = np.take(data, k, axis=axis)
        return step if make is None else make(step, k)

    return TimeSeries(name, int(data.shape[axis]), read)
