"""The Monte Carlo reference: the scene's scattering model with every order of scattering, float64, seeded.

Paths start at the eye through each pixel centre and are traced in the volume's box by **delta
tracking** against a majorant ``sigma_max`` (the transfer function's largest extinction): a tentative
collision after an exponential free flight of rate ``sigma_max``, a real one with probability
``sigma / sigma_max``.  At a real collision at ``x`` the path collects (the collision estimator of the
source term over the extinction)

    throughput * c(x) * ((1 - a) + a * sum over lights of 4 pi p(cos theta) E T(x))

with the lights' transmittance ``T`` by **ratio tracking** (the product of ``1 - sigma / sigma_max``
over tentative collisions to the box's exit, or to a point light), then continues with throughput
times ``a c(x)`` in a direction drawn from the phase function (the angle between the old and the new
path direction, which light travels in reverse), Russian roulette ending weak paths after the third
collision.  With ``max_collisions = 1`` this estimates exactly what the single-scattering references
compute (``tests/renderers/test_scattering.py`` checks it against the converged one); unlimited, it adds
the light scattered more than once, so the difference measures what single scattering leaves out.

Each pixel's value is the mean over its paths and its error estimate the standard error of that mean
(its paths are independent); alpha is the fraction of paths with a real collision (the probability of
one is the pixel's opacity).
"""

from __future__ import annotations

import numpy as np

from ..rays import RayBatch, intersect_box
from ..scene.settings import constant_albedo
from .model import OpticalModel
from .scattering import FOUR_PI

#: Collisions after which Russian roulette may end a path (with probability 1 - its largest channel).
ROULETTE_AFTER = 3
#: Collisions whose lights are sampled together (ratio tracking of their shadow rays in one loop).
NEE_BATCH = 1 << 16


def sample_henyey_greenstein(directions: np.ndarray, g: float, rng: np.random.Generator) -> np.ndarray:
    """New unit directions whose cosine with ``directions`` follows Henyey-Greenstein (isotropic at g = 0),
    by inverting its cumulative distribution."""
    n = len(directions)
    xi = rng.random(n)
    if abs(g) < 1e-6:
        mu = 1.0 - 2.0 * xi
    else:
        s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi)
        mu = (1.0 + g * g - s * s) / (2.0 * g)
    mu = np.clip(mu, -1.0, 1.0)
    phi = 2.0 * np.pi * rng.random(n)
    # an orthonormal frame around each direction
    d = directions
    helper = np.where(np.abs(d[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    u = np.cross(d, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(d, u)
    sin = np.sqrt(np.maximum(0.0, 1.0 - mu * mu))
    return mu[:, None] * d + (sin * np.cos(phi))[:, None] * u + (sin * np.sin(phi))[:, None] * v


class MonteCarloReference:
    """Render a scene with ``[renderer.scattering]`` by path tracing (see the module doc).

    Args:
        scene: emission-absorption with scattering enabled (a grid or any field the references take).
        paths: paths per pixel.
        seed: the random generator's seed (the same seed, the same image).
        max_collisions: collisions a path may have (1: single scattering; None: unlimited).
    """

    def __init__(self, scene, paths: int = 64, seed: int = 0, max_collisions: int | None = None):
        r = scene.renderer
        if r.compositing != "emission_absorption" or not r.scattering.enabled:
            raise ValueError("the Monte Carlo reference renders emission-absorption with scattering enabled")
        self.scene = scene
        self.model = OpticalModel(scene, exact=True)
        self.model.scattering = None  # the paths sample the lights themselves
        self.albedo = constant_albedo(r)
        self.spec = r.scattering
        self.paths = int(paths)
        self.seed = seed
        self.max_collisions = max_collisions
        self.lo, self.hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
        _, node_sigma = scene.transfer_function.evaluate(scene.transfer_function.points[:, 0])
        self.majorant = float(np.max(node_sigma)) if len(node_sigma) else 0.0
        self.min_distance = 0.5 * float(getattr(scene.field, "sample_spacing", 1.0))
        self.stats = {"collisions": 0, "tentative": 0, "above_majorant": 0}

    # --- the medium ---------------------------------------------------------------------------

    def _medium(self, points):
        """``(colour (N, 3), sigma (N,))`` at points, sigma held to the majorant (counted if it passes)."""
        colour, sigma = self.model.emission(points, np.zeros_like(points))
        over = sigma > self.majorant * (1.0 + 1e-12)
        self.stats["above_majorant"] += int(over.sum())
        return colour, np.minimum(sigma, self.majorant)

    def _albedo(self, points) -> np.ndarray:
        """``(N, 1)``: the scene's albedo, or its transfer function's column, at points."""
        albedo = self.model.albedo(points)
        return np.full((len(points), 1), self.albedo) if albedo is None else albedo[:, None]

    def _exit(self, points, directions):
        _, t1 = intersect_box(points, directions, self.lo, self.hi)
        return np.maximum(t1, 0.0)

    def _transmittance(self, points, toward, reach, rng) -> np.ndarray:
        """Ratio tracking from points along ``toward`` over ``[0, reach]``."""
        t = np.zeros(len(points))
        weight = np.ones(len(points))
        live = np.nonzero(reach > 0)[0]
        while len(live) and self.majorant > 0:
            t[live] -= np.log1p(-rng.random(len(live))) / self.majorant
            inside = t[live] < reach[live]
            live = live[inside]
            if not len(live):
                break
            _, sigma = self._medium(points[live] + t[live, None] * toward[live])
            self.stats["tentative"] += len(live)
            weight[live] *= 1.0 - sigma / self.majorant
            live = live[weight[live] > 0]
        return weight

    def _direct(self, points, directions, rng) -> np.ndarray:
        """``sum 4 pi p(cos theta) E T`` (RGB) at points, the path arriving along ``directions``."""
        from .scattering import phase_function

        phase = phase_function(self.spec)
        total = np.zeros(points.shape)
        for light in self.spec.lights:
            irradiance = light.intensity * np.asarray(light.color, dtype=np.float64)
            if light.type == "directional":
                w = np.asarray(light.direction, dtype=np.float64)
                toward = np.broadcast_to(-w / np.linalg.norm(w), points.shape).copy()
                energy = np.broadcast_to(irradiance, points.shape)
                reach = self._exit(points, toward)
            else:
                v = np.asarray(light.position, dtype=np.float64) - points
                distance = np.linalg.norm(v, axis=1)
                toward = np.where(distance[:, None] > 0, v / np.maximum(distance, 1e-300)[:, None],
                                  np.array([0.0, 0.0, 1.0]))
                energy = irradiance / np.maximum(distance, self.min_distance)[:, None] ** 2
                reach = np.minimum(self._exit(points, toward), distance)
            weight = FOUR_PI * phase(np.sum(toward * directions, axis=1))[:, None] * energy
            if self.spec.shadows:
                weight = weight * self._transmittance(points, toward, reach, rng)[:, None]
            total += weight
        return total

    # --- the paths ----------------------------------------------------------------------------

    def render(self) -> tuple[np.ndarray, np.ndarray]:
        """``(image (H, W, 4), standard error (H, W, 4))``, premultiplied linear RGBA, float64."""
        scene = self.scene
        width, height = scene.image.width, scene.image.height
        rays = RayBatch.for_camera(scene.camera, width, height, scene.field.bounds)
        rng = np.random.default_rng(self.seed)
        pixel = np.repeat(np.arange(len(rays)), self.paths)
        start = np.repeat(rays.t0, self.paths)
        hit = np.repeat(rays.t1 > rays.t0, self.paths)
        pixel, start = pixel[hit], start[hit]
        position = rays.origins[pixel] + start[:, None] * rays.directions[pixel]
        direction = rays.directions[pixel].copy()
        throughput = np.ones((len(pixel), 3))
        collisions = np.zeros(len(pixel), np.int64)
        # per path: its sum (RGB) and whether it collided (alpha); moments per pixel at the end
        total = np.zeros((len(pixel), 3))
        collided = np.zeros(len(pixel))
        live = np.arange(len(pixel))
        t = np.zeros(len(pixel))
        reach = self._exit(position, direction)
        pending, waiting = [], 0  # collisions whose lights are still to be sampled
        while len(live) and self.majorant > 0:
            t[live] -= np.log1p(-rng.random(len(live))) / self.majorant
            inside = t[live] < reach[live]
            live = live[inside]  # the others left the box
            if not len(live):
                break
            x = position[live] + t[live, None] * direction[live]
            colour, sigma = self._medium(x)
            self.stats["tentative"] += len(live)
            real = rng.random(len(live)) * self.majorant < sigma
            p, x, colour = live[real], x[real], colour[real]
            a = self._albedo(x)
            self.stats["collisions"] += len(p)
            # the emitted part now; the lights' part (its ratio tracking) in batches, later
            total[p] += throughput[p] * colour * (1.0 - a)
            if np.any(a > 0.0):
                pending.append((p, throughput[p] * colour * a, x, direction[p].copy()))
                waiting += len(p)
                if waiting >= NEE_BATCH:
                    self._lights(pending, total, rng)
                    pending, waiting = [], 0
            collided[p[collisions[p] == 0]] = 1.0
            collisions[p] += 1
            # continue: scattered (weight a c), unless the path has had its collisions
            go = a[:, 0] > 0.0
            if self.max_collisions is not None:
                go &= collisions[p] < self.max_collisions
            throughput[p] *= a * colour
            late = collisions[p] >= ROULETTE_AFTER
            keep = np.minimum(1.0, throughput[p].max(axis=1))
            survive = ~late | (rng.random(len(p)) < keep)
            throughput[p] = np.where((late & survive)[:, None], throughput[p] / np.maximum(keep, 1e-300)[:, None],
                                     throughput[p])
            go &= survive & (throughput[p].max(axis=1) > 0)
            stop = set(p[~go].tolist())
            moved = p[go]
            if len(moved):
                position[moved] = x[go]
                direction[moved] = sample_henyey_greenstein(direction[moved], self.spec.g if
                                                            self.spec.phase == "henyey_greenstein" else 0.0, rng)
                t[moved] = 0.0
                reach[moved] = self._exit(position[moved], direction[moved])
            if stop:
                live = live[~np.isin(live, p[~go])]
        self._lights(pending, total, rng)
        return self._moments(pixel, total, collided, len(rays), width, height)

    def _lights(self, pending, total, rng):
        """The lights' part of collisions ``(paths, weight, points, directions)``, added to the paths' sums
        (many collisions at once: ratio tracking steps them together)."""
        if not pending:
            return
        p, weight, x, d = (np.concatenate([c[i] for c in pending]) for i in range(4))
        np.add.at(total, p, weight * self._direct(x, d, rng))

    def _moments(self, pixel, total, collided, count, width, height):
        values = np.concatenate([total, collided[:, None]], axis=1)
        n = self.paths
        mean = np.zeros((count, 4))
        square = np.zeros((count, 4))
        for c in range(4):
            mean[:, c] = np.bincount(pixel, values[:, c], minlength=count) / n
            square[:, c] = np.bincount(pixel, values[:, c] ** 2, minlength=count) / n
        variance = np.maximum(square - mean ** 2, 0.0) * n / max(n - 1, 1)
        error = np.sqrt(variance / n)
        return mean.reshape(height, width, 4), error.reshape(height, width, 4)
