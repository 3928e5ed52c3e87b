"""Camera: look-at or orbit, perspective or orthographic, one ray per pixel centre.

World units throughout; angles in degrees.  The orbit frame is built from
``up`` (default +z, the slice axis of most scans): at azimuth 0 and
elevation 0 the eye is on the -y side of the target looking toward +y;
azimuth turns the eye toward +x (counter-clockwise seen from +up) and
elevation lifts it toward +up.  Image row 0 is the top row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .checks import WORLD_RANGE, between, world_length
from .errors import SceneError

PROJECTIONS = ("perspective", "orthographic")
#: What the lens keys allow, as scene-file checks (``[camera]`` in :mod:`dvr_gl.scene.schema` uses these too,
#: so a scene and a Camera built in Python are refused with the same words).
#: The narrowest field of view (degrees).  Narrower, the framing distance (about 57000 times the object's radius
#: over the fov) outgrows float32 (fov 1e-12 drew half the picture, 1e-300 a black one, 5e-324 divided by zero);
#: a view without perspective is the orthographic projection.
MIN_FOV = 1e-3
LENS_CHECKS = {"fov": between(MIN_FOV, 180, open_hi=True, what=" degrees"),
               "view_height": world_length, "near": between(0, WORLD_RANGE[1], what=" world units")}


def _unit(v, what: str) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    scale = np.max(np.abs(v)) if v.size else 0.0
    if not np.isfinite(scale) or scale == 0:
        raise SceneError(f"camera: {what} must be a non-zero vector, got {v.tolist()}")
    v = v / scale  # first to the largest component: no overflow or underflow in the norm (up = 1e300, 0, 0)
    return v / np.linalg.norm(v)


def orbit_frame(up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(up, front, side)``: the eye direction at azimuth 0 is ``front``, at azimuth 90 ``side``."""
    u = _unit(up, "up")
    front = np.array([0.0, -1.0, 0.0]) - u * (-u[1])
    if np.linalg.norm(front) < 1e-9:  # up along y: use -z as the front
        front = np.array([0.0, 0.0, -1.0]) - u * (-u[2])
    front /= np.linalg.norm(front)
    return u, front, np.cross(u, front)


def orbit_eye(target, up, azimuth: float, elevation: float, distance: float) -> np.ndarray:
    """Eye position of an orbit about ``target`` (angles in degrees)."""
    u, front, side = orbit_frame(up)
    az, el = math.radians(azimuth), math.radians(elevation)
    direction = math.cos(el) * (math.cos(az) * front + math.sin(az) * side) + math.sin(el) * u
    return np.asarray(target, dtype=np.float64) + distance * direction


def orbit_of(eye, target, up) -> tuple[float, float, float]:
    """``(azimuth, elevation, distance)`` that put the eye at ``eye``."""
    u, front, side = orbit_frame(up)
    d = np.asarray(eye, dtype=np.float64) - np.asarray(target, dtype=np.float64)
    dist = float(np.linalg.norm(d))
    if dist == 0:
        raise SceneError("camera.eye and camera.target coincide; move the eye")
    d = d / dist
    el = math.degrees(math.asin(max(-1.0, min(1.0, float(d @ u)))))
    az = math.degrees(math.atan2(float(d @ side), float(d @ front)))
    return az, el, dist


@dataclass(frozen=True, repr=False)
class Camera:
    """A pinhole (perspective) or parallel (orthographic) camera.

    Attributes:
        eye, target, up: look-at, world units.
        projection: ``perspective`` or ``orthographic``.
        fov: vertical field of view in degrees (perspective).
        view_height: height of the view in world units (orthographic).
        near: distance of the near plane from the eye along the view axis;
            rays start there (or where they enter the volume, if later).
        orbit: ``(azimuth, elevation, distance)`` when the eye was computed from an
            orbit, so that a saved scene repeats the same computation; else None.
    """

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    projection: str = "perspective"
    fov: float = 30.0
    view_height: float = 1.0
    near: float = 0.0
    orbit: tuple[float, float, float] | None = None

    def __post_init__(self):
        if self.projection not in PROJECTIONS:
            raise SceneError(f"camera: projection {self.projection!r} is not one of {', '.join(PROJECTIONS)}")
        for key, check in LENS_CHECKS.items():
            value = getattr(self, key)
            if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
                raise SceneError(f"camera.{key} must be a number, got {value!r}")
            problem = check(value) if math.isfinite(value) else "must be a finite number"
            if problem:
                raise SceneError(f"camera.{key} {problem}, got {value}")
        for name in ("eye", "target", "up"):
            try:
                v = tuple(float(x) for x in getattr(self, name))
            except (TypeError, ValueError):
                raise SceneError(f"camera.{name} must be three numbers, got {getattr(self, name)!r}") from None
            limit = math.inf if name == "up" else WORLD_RANGE[1]  # up is a direction: any finite length
            if len(v) != 3 or not all(abs(x) <= limit for x in v):  # NaN fails too
                raise SceneError(f"camera.{name} must be three finite numbers"
                                 f"{'' if name == 'up' else f' within {limit:g} of the origin'}, got {list(v)}")
            object.__setattr__(self, name, v)
        _unit(np.subtract(self.target, self.eye), "target - eye")
        _unit(self.up, "up")

    @classmethod
    def from_orbit(cls, target, up, azimuth: float, elevation: float, distance: float, **kw) -> "Camera":
        problem = world_length(distance) if math.isfinite(distance) else "must be a finite number"
        if problem:
            raise SceneError(f"camera.distance {problem}, got {distance}")
        eye = orbit_eye(target, up, azimuth, elevation, distance)
        return cls(tuple(eye), tuple(target), tuple(up), orbit=(azimuth, elevation, distance), **kw)

    def orbited(self, azimuth=None, elevation=None, distance=None) -> "Camera":
        """The same camera moved on its orbit; unspecified parameters are kept."""
        az, el, dist = self.orbit if self.orbit else orbit_of(self.eye, self.target, self.up)
        az = az if azimuth is None else azimuth
        el = el if elevation is None else elevation
        dist = dist if distance is None else distance
        return Camera.from_orbit(self.target, self.up, az, el, dist, projection=self.projection,
                                 fov=self.fov, view_height=self.view_height, near=self.near)

    def with_(self, **changes) -> "Camera":
        return replace(self, **changes)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(forward, right, up)`` orthonormal; right-handed, right x up = -forward.  Computed once per
        camera (a frame asks hundreds of times: 6 ms of a small mesh's 12 ms frame, measured 2026-11-28);
        each call returns fresh copies, so a caller may change them."""
        cached = self.__dict__.get("_basis")
        if cached is None:
            cached = self._basis_computed()
            object.__setattr__(self, "_basis", cached)  # frozen: the fields never change, so neither does this
        return tuple(v.copy() for v in cached)

    def _basis_computed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        f = _unit(np.subtract(self.target, self.eye), "view direction")
        r = np.cross(f, _unit(self.up, "up"))  # up may be any length (1e300): normalized first
        if np.linalg.norm(r) < 1e-12:
            # Looking along up: take right from the orbit frame so it is continuous
            # with nearby views (at the pole, the azimuth sets the image rotation).
            u, front, side = orbit_frame(self.up)
            az = math.radians(self.orbit[0]) if self.orbit else 0.0
            r = np.cross(u, math.cos(az) * front + math.sin(az) * side)
        r /= np.linalg.norm(r)
        return f, r, np.cross(r, f)

    def half_extent(self, aspect: float) -> tuple[float, float]:
        """Half the width and height of the view: in the plane one unit in front of the eye
        (perspective: ``tan(fov / 2)`` high), or in world units (orthographic: ``view_height / 2``),
        for an image of ``aspect`` = width / height.  The one place the projection is written:
        rays, the ray caster's uniforms, the slicers' projection matrix, shear-warp's factorization
        and the viewer's pan and zoom all take it from here."""
        half_h = math.tan(math.radians(self.fov) / 2.0) if self.projection == "perspective" else self.view_height / 2.0
        return half_h * aspect, half_h

    def corner_directions(self, width: int, height: int) -> np.ndarray:
        """Unit directions ``(5, 3)`` of the view axis and the rays through the image's four corners
        (all five the view axis when orthographic): any linear-fractional function of the ray
        direction, such as the ray length between two planes, takes its extremes among them."""
        f, r, u = self.basis()
        if self.projection == "orthographic":
            return np.tile(f, (5, 1))
        half_w, half_h = self.half_extent(width / height)
        dirs = [f] + [f + sx * half_w * r + sy * half_h * u for sx in (-1, 1) for sy in (-1, 1)]
        return np.array([d / np.linalg.norm(d) for d in dirs])

    def pixel_rays(self, width: int, height: int, pixels: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions ``(H*W, 3)`` through every pixel centre, row 0 at the top (only
        through ``pixels``, flat indices in that order, when given).

        Perspective rays start at the eye; orthographic rays start on the plane
        through the eye perpendicular to the view direction.
        """
        f, r, u = self.basis()
        index = np.arange(width * height) if pixels is None else np.asarray(pixels)
        xx = (((index % width) + 0.5) / width * 2.0 - 1.0).reshape(-1, 1)
        yy = (1.0 - ((index // width) + 0.5) / height * 2.0).reshape(-1, 1)
        half_w, half_h = self.half_extent(width / height)
        eye = np.array(self.eye)
        if self.projection == "perspective":
            d = f + xx * half_w * r + yy * half_h * u
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            o = np.broadcast_to(eye, d.shape).copy()
        else:
            o = eye + xx * half_w * r + yy * half_h * u
            d = np.broadcast_to(f, o.shape).copy()
        return o, d

    def pixel_rectangle(self, points, width: int, height: int, margin: int = 1) -> tuple[int, int, int, int] | None:
        """``(x, y, w, h)`` in pixels, rows counted from the bottom (GL's window coordinates, a scissor box):
        every pixel whose ray through its centre meets the convex hull of ``points`` (world, ``(n, 3)``), with
        ``margin`` pixels more on every side for rounding; clamped to the image (``w`` or ``h`` 0: no pixel).
        None where it cannot tell: a point at or behind the eye's plane (perspective), which projects
        nowhere.  A ray meets the hull only through the hull's projection, which lies within the points'
        projected bounding rectangle: the rays are straight lines through the eye (or parallel)."""
        f, r, u = self.basis()
        rel = np.asarray(points, dtype=np.float64) - np.asarray(self.eye)
        half_w, half_h = self.half_extent(width / height)
        x, y = rel @ r / half_w, rel @ u / half_h  # normalized device coordinates, times the depth (perspective)
        if self.projection == "perspective":
            z = rel @ f
            if not np.all(z > 1e-9 * max(1.0, float(np.abs(rel).max()))):
                return None
            x, y = x / z, y / z
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            return None
        # pixel i's centre is at ndc (i + 0.5) / size * 2 - 1: the pixels from the first centre at or after the
        # least coordinate to the last at or before the largest, widened by the margin
        def span(lo: float, hi: float, size: int) -> tuple[int, int]:
            first = math.ceil(max(-1.0, (lo + 1.0) * size / 2.0 - 0.5)) - margin
            last = math.floor(min(size + 1.0, (hi + 1.0) * size / 2.0 - 0.5)) + margin
            first, last = min(max(first, 0), size), min(last, size - 1)
            return first, max(last - first + 1, 0)

        x0, w = span(float(x.min()), float(x.max()), width)
        y0, h = span(float(y.min()), float(y.max()), height)
        return x0, y0, w, h

    def near_distance(self, directions: np.ndarray) -> np.ndarray:
        """Ray parameter of the near plane along each (unit) direction."""
        if self.near == 0:
            return np.zeros(len(directions))
        f, _, _ = self.basis()
        return self.near / (directions @ f)

    def __repr__(self) -> str:
        fmt = lambda v: "(" + ", ".join(f"{x:.4g}" for x in v) + ")"  # noqa: E731
        lens = f"fov={self.fov:g}" if self.projection == "perspective" else f"view_height={self.view_height:.4g}"
        where = (f"azimuth={self.orbit[0]:g}, elevation={self.orbit[1]:g}, distance={self.orbit[2]:.4g}"
                 if self.orbit else f"eye={fmt(self.eye)}")
        return f"Camera({self.projection}, {where}, target={fmt(self.target)}, {lens})"

    def to_dict(self) -> dict:
        d = {"projection": self.projection, "target": list(self.target), "up": list(self.up),
             "near": self.near}
        if self.orbit:
            d.update(azimuth=self.orbit[0], elevation=self.orbit[1], distance=self.orbit[2])
        else:
            d["eye"] = list(self.eye)
        d["fov" if self.projection == "perspective" else "view_height"] = (
            self.fov if self.projection == "perspective" else self.view_height)
        return d


DEFAULT_AZIMUTH = 30.0
DEFAULT_ELEVATION = 20.0
FRAME_MARGIN = 1.05


def framing_distance(radius: float, fov: float, aspect: float) -> float:
    """Eye distance at which a sphere of ``radius`` fits the view (with a 5 % margin)."""
    half_v = math.radians(fov) / 2.0
    half = min(half_v, math.atan(math.tan(half_v) * aspect))
    return FRAME_MARGIN * radius / math.sin(half)


def framing_view_height(radius: float, aspect: float) -> float:
    """Orthographic view height that fits a sphere of ``radius`` (with a 5 % margin)."""
    return FRAME_MARGIN * 2.0 * radius * max(1.0, 1.0 / aspect)
