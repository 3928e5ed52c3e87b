"""Several fields in one scene (data kind ``"fields"``): :class:`FieldSet`, the channels of a microscope,
a CT with its segmentation, a fusion of CT and PET, composited *per sample* in depth order.

Each member is a regular grid (:class:`~dvr_gl.fields.grid.Volume`) with its own dims, spacing, origin and
orientation and a *role* that says how a sample of it is classified:

* ``"scalar"``: a value, through its own transfer function;
* ``"label"``: an integer label map, through a categorical table (colour and opacity per label), never
  interpolated between labels (:mod:`dvr_gl.labels`);
* ``"rgb"``: a colour volume (:mod:`dvr_gl.fields.color`): colour from the data, opacity from a transfer
  function of its fourth component (luminance or alpha).

The mixture at a point (docs/several-fields.md): extinctions add and emissions add,
``sigma = sum_i sigma_i``, ``sigma c = sum_i sigma_i c_i``, each member contributing only inside its own
box (:attr:`Member.bounds`); the ray's extent is the union of the boxes (:attr:`FieldSet.bounds`).
Each member has its own orientation (direction matrix, :mod:`dvr_gl.orientation`).  The scene's frame, the
*shared frame* the renderers work in, is the first member's own frame; a member whose direction differs is
an oriented box there, reached by the rigid map :meth:`FieldSet.to_member` from shared-frame points to its own
frame (``q = A p + b``, ``A = D_m^T D_0``: see :func:`member_transform`).  Members whose direction equals
the first's (within 1e-6) map by the identity and are treated exactly as before.  :attr:`FieldSet.bounds` is
the union of the members' boxes' bounding boxes in the shared frame.

A single scalar grid is never a FieldSet: it stays a :class:`Volume` (kind ``"grid"``), so that a scene
of one field renders exactly as it always did.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import SceneError

ROLES = ("scalar", "label", "rgb")


@dataclass(frozen=True)
class Member:
    """One field of a :class:`FieldSet`: a grid, its role (:data:`ROLES`) and a name for messages and
    legends (a channel's name from its file, else ``"channel k"``)."""

    field: object
    role: str = "scalar"
    name: str = ""

    def __post_init__(self):
        if self.role not in ROLES:
            raise SceneError(f"{self.name or 'field'}: role must be one of {', '.join(ROLES)}, got {self.role!r}")
        if getattr(self.field, "kind", None) != "grid":
            raise SceneError(f"{self.name or 'field'}: several fields in one scene must each be a regular grid; "
                             f"this one is {getattr(self.field, 'kind', type(self.field).__name__)}: resample it "
                             f"(volume.resample) or render it alone")
        colour = getattr(self.field, "role", None) == "rgb"  # a ColorVolume: its voxels are colour, not values
        if colour != (self.role == "rgb"):
            raise SceneError(f"{self.name or self.field.name}: role {self.role} " + (
                "takes scalars; this is a colour volume: give it role rgb" if colour else
                "needs a colour volume (dvr_gl.fields.color.ColorVolume, e.g. ColorVolume.from_srgb(array)); "
                "this field holds scalars"))

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.field.bounds


def same_grid(a, b) -> bool:
    """Whether two grids sample the same points (dims, spacing, origin, direction): channels of one array,
    which travel in one texture."""
    return (a.dims == b.dims and np.allclose(a.spacing, b.spacing, rtol=1e-9, atol=0)
            and np.allclose(a.origin, b.origin, rtol=0, atol=1e-9 * max(a.spacing))
            and np.allclose(a.direction, b.direction, atol=1e-9))


@dataclass(frozen=True, eq=False, repr=False)
class FieldSet:
    """Several grids in one scene, composited per sample (see the module doc).  ``members`` in the scene's
    order (that of its ``[[volume]]`` tables and of a file's channels)."""

    members: tuple

    kind = "fields"
    out_of_core = False

    def __post_init__(self):
        # a bare field: a scalar member, or an rgb one where the field is colour (its own role)
        members = tuple(m if isinstance(m, Member) else Member(m, getattr(m, "role", "scalar"), getattr(m, "name", ""))
                        for m in self.members)
        if not members:
            raise SceneError("a scene of several fields needs at least one field")
        for m in members:
            if getattr(m.field, "kind", None) != "grid":
                Member(m.field, m.role, m.name)  # refused there, in one line
        object.__setattr__(self, "members", members)
        object.__setattr__(self, "transforms", tuple(member_transform(members[0].field, m.field) for m in members))

    @property
    def fields(self) -> tuple:
        return tuple(m.field for m in self.members)

    @property
    def name(self) -> str:
        return " + ".join(m.name or m.field.name for m in self.members)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The union of the members' boxes (world units, the shared frame): an oriented member counts by the
        axis-aligned bounding box of its box in the shared frame (:meth:`member_bounds`)."""
        los, his = zip(*(self.member_bounds(i) for i in range(len(self.members))))
        return np.min(los, axis=0), np.max(his, axis=0)

    @property
    def oriented(self) -> bool:
        """Whether any member's direction differs from the first's (its map is not the identity)."""
        return any(t is not None for t in self.transforms)

    def to_member(self, i: int, points) -> np.ndarray:
        """Shared-frame points ``(..., 3)`` in member ``i``'s own frame (world units, where its box is
        axis-aligned: sample ``(i, j, k)`` at ``origin + (i sx, j sy, k sz)``)."""
        points = np.asarray(points, dtype=np.float64)
        if self.transforms[i] is None:
            return points
        a, b = self.transforms[i]
        return points @ a.T + b

    def member_bounds(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Member ``i``'s box in the shared frame: the box itself, or for an oriented member the axis-aligned
        bounding box of its eight corners mapped back (``p = A^T (q - b)``)."""
        lo, hi = self.members[i].bounds
        if self.transforms[i] is None:
            return lo, hi
        a, b = self.transforms[i]
        corners = np.array([[(lo, hi)[(c >> k) & 1][k] for k in range(3)] for c in range(8)], dtype=np.float64)
        shared = (corners - b) @ a
        return shared.min(axis=0), shared.max(axis=0)

    box = bounds

    @property
    def value_range(self) -> tuple[float, float]:
        """The first member's (what a single transfer function would span)."""
        return self.members[0].field.value_range

    @property
    def sample_spacing(self) -> float:
        """One voxel: the smallest spacing of any member (world units)."""
        return min(m.field.sample_spacing for m in self.members)

    @property
    def direction(self):
        return self.members[0].field.direction

    @property
    def origin(self):
        """The first member's origin: the point the orientation turns about (:mod:`dvr_gl.orientation`)."""
        return self.members[0].field.origin

    @property
    def nbytes(self) -> int:
        return sum(m.field.nbytes for m in self.members)

    def groups(self, per_texture: int = 4) -> list[list[int]]:
        """Member indices grouped as they travel to a GPU: scalar and label members on the same grid share
        a texture, up to ``per_texture`` each; an RGB member fills one of its own."""
        out: list[list[int]] = []
        for i, m in enumerate(self.members):
            if m.role != "rgb":
                for g in out:
                    first = self.members[g[0]]
                    if (first.role != "rgb" and len(g) < per_texture and first.field.dtype == m.field.dtype
                            and same_grid(first.field, m.field)):
                        g.append(i)
                        break
                else:
                    out.append([i])
            else:
                out.append([i])
        return out

    def describe(self) -> str:
        return "; ".join(f"[{m.role}] {m.field.describe()}" for m in self.members)

    def __len__(self) -> int:
        return len(self.members)

    def __repr__(self) -> str:
        return f"FieldSet({', '.join(f'{m.name or m.field.name}:{m.role}' for m in self.members)})"


def member_transform(first, field):
    """The rigid map ``(A, b)`` from the first member's own frame (the shared frame) to ``field``'s own frame,
    ``q = A p + b``, or None where their direction matrices agree (within 1e-6: the identity).

    With ``world = o + D (p - o)`` (:func:`dvr_gl.orientation.to_patient_frame`) for each: ``A = D_m^T D_0`` and
    ``b = o_m - A o_0 + D_m^T (o_0 - o_m)``.  The directions are orthonormal (:func:`~dvr_gl.fields.grid.
    check_direction`), so ``A`` is too (a rotation, or one with a mirror): distances, and so ray parameters,
    are kept; a gradient ``g_m`` in the member's frame is ``A^T g_m`` in the shared frame."""
    d0 = np.asarray(first.direction, dtype=np.float64)
    dm = np.asarray(field.direction, dtype=np.float64)
    if np.allclose(dm, d0, atol=1e-6):
        return None
    o0, om = np.asarray(first.origin, dtype=np.float64), np.asarray(field.origin, dtype=np.float64)
    a = dm.T @ d0
    return a, om - a @ o0 + dm.T @ (o0 - om)


class Layer(NamedTuple):
    """A field of a scene with its classification (:attr:`dvr_gl.scene.resolve.Scene.layers`)."""

    field: object
    role: str
    name: str
    transfer_function: object
    iso_value: float | None = None  # isosurface: where this field's surface is (data units)


def as_data(members) -> object:
    """One scalar member: its field alone (kind ``"grid"``); otherwise a :class:`FieldSet`."""
    members = tuple(members)
    if len(members) == 1 and members[0].role == "scalar":
        return members[0].field
    return FieldSet(members)


def members_of(field) -> tuple:
    """The members of a scene's data: a FieldSet's, or the field itself as one scalar member."""
    if isinstance(field, FieldSet):
        return field.members
    return (_single(field),)


def _single(field) -> Member:
    m = object.__new__(Member)  # no checks: a single field of any kind is one scalar member
    object.__setattr__(m, "field", field)
    object.__setattr__(m, "role", "scalar")
    object.__setattr__(m, "name", getattr(field, "name", ""))
    return m
