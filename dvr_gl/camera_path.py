"""Camera paths: cameras at keyframe times, interpolated smoothly between them.

A keyframe is a :class:`~dvr_gl.camera.Camera` at a time (seconds).  Between keyframes:

* the camera's rotation (its ``(right, up, back)`` frame as a unit quaternion) follows Shoemake's
  spherical quadrangle interpolation (SQUAD): on the sphere of rotations, through every keyframe, with
  a continuous turning rate at keyframes evenly spaced in time; between two keyframes alone it is the
  spherical linear interpolation (slerp): the view direction turns about one axis at a constant angular
  speed.  Up stays orthogonal to the view direction: both are columns of one rotation.
* the distance from the eye to the target in log space, the target, and the field of view (the view
  height, orthographic: in log space) along a cubic Hermite spline in time with Catmull-Rom slopes
  inside and the chord's slope at the ends: with two keyframes, a straight line in time (so a constant
  distance stays constant: the eye moves on the sphere about the target).
* the eye: the target minus the distance along the view direction.

Every keyframe shares the first's projection and near plane.  Times are seconds; a frame of an
animation of N frames samples the path at ``start + i (end - start) / (N - 1)``: the first and the last
keyframes are its first and last frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera import Camera
from .errors import SceneError


def _quaternion(m: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` of rotation matrix ``m`` (Shepperd's method: the largest
    diagonal term first, so no division by a small number)."""
    t = np.trace(m)
    i = int(np.argmax([t, m[0, 0], m[1, 1], m[2, 2]]))
    if i == 0:
        s = 2.0 * math.sqrt(1.0 + t)
        q = [s / 4, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif i == 1:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif i == 2:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4]
    q = np.array(q)
    return q / np.linalg.norm(q)


def _matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _multiply(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _conjugate(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _log(q):
    """Of a unit quaternion: the pure quaternion ``(0, axis * angle / 2)``."""
    v = q[1:]
    s = np.linalg.norm(v)
    return np.zeros(4) if s < 1e-15 else np.concatenate([[0.0], v / s * math.atan2(s, q[0])])


def _exp(p):
    v = p[1:]
    a = np.linalg.norm(v)
    return np.array([1.0, 0.0, 0.0, 0.0]) if a < 1e-15 else np.concatenate([[math.cos(a)], v / a * math.sin(a)])


def slerp(a: np.ndarray, b: np.ndarray, h: float) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions (``b`` taken on ``a``'s side of the sphere)."""
    if a @ b < 0:
        b = -b
    return _multiply(a, _exp(h * _log(_multiply(_conjugate(a), b))))


def _hermite(p0, p1, m0, m1, h, dt):
    h2, h3 = h * h, h * h * h
    return ((2 * h3 - 3 * h2 + 1) * p0 + (h3 - 2 * h2 + h) * dt * m0 + (-2 * h3 + 3 * h2) * p1
            + (h3 - h2) * dt * m1)


def _slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Catmull-Rom slopes (the mean of the two chords' slopes) inside; the chord's at the ends."""
    chords = np.diff(values, axis=0) / np.diff(times).reshape(-1, *([1] * (values.ndim - 1)))
    slopes = np.empty_like(values)
    slopes[0], slopes[-1] = chords[0], chords[-1]
    slopes[1:-1] = (chords[:-1] + chords[1:]) / 2.0
    return slopes


@dataclass(frozen=True)
class CameraPath:
    """Cameras at increasing ``times`` (seconds), interpolated smoothly (module docstring).

    ``camera_at(t)`` is the camera at time ``t`` (clamped to the path's span); ``frame_times(n)`` the times
    of an animation's ``n`` frames.  Refused in one line: fewer than two keyframes, times that do not
    increase, keyframes of different projections, a look-at keyframe whose up is parallel to its view.
    """

    cameras: tuple
    times: tuple
    steps: tuple | None = None  # a time series' step at each keyframe (step_at), or None

    def __post_init__(self):
        cameras, times = tuple(self.cameras), tuple(float(t) for t in self.times)
        object.__setattr__(self, "cameras", cameras)
        object.__setattr__(self, "times", times)
        if len(cameras) < 2 or len(cameras) != len(times):
            raise SceneError(f"camera.keyframe: a path needs at least two keyframes, each with a time; got "
                             f"{len(cameras)}")
        if self.steps is not None:
            steps = tuple(self.steps)
            if len(steps) != len(times) or not all(isinstance(k, int) and k >= 0 for k in steps):
                raise SceneError(f"camera.keyframe: give every keyframe a step (an integer >= 0) or none, got "
                                 f"{list(steps)}")
            object.__setattr__(self, "steps", steps)
        if not all(map(math.isfinite, times)) or any(b <= a for a, b in zip(times, times[1:])):
            raise SceneError(f"camera.keyframe: the times must be finite and increase from one keyframe to the "
                             f"next, got {list(times)}")
        for k, c in enumerate(cameras):
            if c.projection != cameras[0].projection:
                raise SceneError(f"camera.keyframe[{k}]: projection {c.projection} differs from the first "
                                 f"keyframe's {cameras[0].projection}; one path has one projection")
            f = np.subtract(c.target, c.eye)
            f = f / np.linalg.norm(f)
            u = np.asarray(c.up) / np.linalg.norm(c.up)
            if c.orbit is None and np.linalg.norm(np.cross(f, u)) < 1e-9:
                raise SceneError(f"camera.keyframe[{k}]: up {list(c.up)} is parallel to the view direction "
                                 f"(target - eye); give an up across the view")
        frames = [np.column_stack(self._frame(c)) for c in cameras]
        quats = [_quaternion(m) for m in frames]
        for k in range(1, len(quats)):  # each on the previous one's side of the sphere: the short way round
            if quats[k] @ quats[k - 1] < 0:
                quats[k] = -quats[k]
        object.__setattr__(self, "_quats", quats)
        object.__setattr__(self, "_inner", self._squad_controls(quats))
        t = np.array(times)
        distances = np.log([np.linalg.norm(np.subtract(c.target, c.eye)) for c in cameras])
        lens = np.array([c.fov if c.projection == "perspective" else math.log(c.view_height) for c in cameras])
        targets = np.array([c.target for c in cameras], dtype=np.float64)
        object.__setattr__(self, "_tracks", [(v, _slopes(t, v)) for v in (distances, lens, targets)])

    @staticmethod
    def _frame(camera):
        f, r, u = camera.basis()
        return r, u, -f

    @staticmethod
    def _squad_controls(q):
        """SQUAD's inner quaternions ``s_i = q_i exp(-(log(q_i^-1 q_(i+1)) + log(q_i^-1 q_(i-1))) / 4)``; the
        ends their own keyframes'."""
        out = [q[0]]
        for i in range(1, len(q) - 1):
            inv = _conjugate(q[i])
            out.append(_multiply(q[i], _exp(-(_log(_multiply(inv, q[i + 1])) + _log(_multiply(inv, q[i - 1]))) / 4)))
        return out + [q[-1]]

    @property
    def start(self) -> float:
        return self.times[0]

    @property
    def end(self) -> float:
        return self.times[-1]

    def frame_times(self, frames: int) -> np.ndarray:
        """The times of an animation's ``frames`` frames: the span sampled evenly, both ends included."""
        return np.linspace(self.start, self.end, frames) if frames > 1 else np.array([self.start])

    def step_at(self, t: float) -> int | None:
        """The time series' step at time ``t``: the keyframes' steps joined by straight lines in time, rounded
        down (a keyframe's own at its time); None where the keyframes give none."""
        if self.steps is None:
            return None
        i, h = self._segment(t)
        return int(math.floor(self.steps[i] + h * (self.steps[i + 1] - self.steps[i]) + 1e-9))

    def rotation_at(self, t: float) -> np.ndarray:
        """The camera's ``(right, up, back)`` columns at time ``t`` (a rotation matrix)."""
        i, h = self._segment(t)
        q, s = self._quats, self._inner
        a, b = slerp(q[i], q[i + 1], h), slerp(s[i], s[i + 1], h)
        return _matrix(slerp(a, b, 2.0 * h * (1.0 - h)))

    def _segment(self, t: float) -> tuple[int, float]:
        t = min(max(float(t), self.start), self.end)
        i = min(int(np.searchsorted(self.times, t, side="right")) - 1, len(self.times) - 2)
        return i, (t - self.times[i]) / (self.times[i + 1] - self.times[i])

    def keyframe_tables(self) -> list[dict]:
        """The keyframes as ``[[camera.keyframe]]`` tables (look-at: ``time``, ``eye``, ``target``, ``up`` and
        the lens), which a scene file reads back to this path (:meth:`dvr_gl.Scene.with_camera_path`; what a
        viewer or a notebook that records a path writes)."""
        tables = []
        for t, c in zip(self.times, self.cameras):
            lens = {"fov": c.fov} if c.projection == "perspective" else {"view_height": c.view_height}
            tables.append({"time": t, "eye": list(c.eye), "target": list(c.target), "up": list(c.basis()[2]),
                           **lens})
            if self.steps is not None:
                tables[-1]["step"] = self.steps[len(tables) - 1]
        return tables

    def camera_at(self, t: float) -> Camera:
        """The camera at time ``t`` (seconds; clamped to the path's span); a keyframe's own at its time."""
        if t in self.times:
            return self.cameras[self.times.index(t)]
        i, h = self._segment(t)
        dt = self.times[i + 1] - self.times[i]
        log_distance, lens, target = (_hermite(v[i], v[i + 1], m[i], m[i + 1], h, dt) for v, m in self._tracks)
        r, u, back = self.rotation_at(t).T
        first = self.cameras[0]
        eye = target + math.exp(log_distance) * back
        lo, hi = min(self._tracks[1][0][i:i + 2]), max(self._tracks[1][0][i:i + 2])
        lens = min(max(lens, lo), hi) if len(self.times) > 2 else lens  # no Catmull-Rom overshoot of a lens
        if first.projection == "perspective":
            return Camera(tuple(eye), tuple(target), tuple(u), "perspective", fov=float(lens), near=first.near)
        return Camera(tuple(eye), tuple(target), tuple(u), "orthographic", view_height=math.exp(lens),
                      near=first.near)
