"""``dvr bench splatting --peers``: the column density of SPH particles, dvr-gl's splatting against sarracen
(a numba CPU code: ``interpolate_3d_proj``), in one interleaved run.

The same particles (a Plummer sphere, :func:`~dvr_gl.fields.particles.plummer_sphere`), the same M4 cubic
spline with SPLASH's support of ``2h``, the same window (the particles' extent in x and y, square) and
image size, viewed along -z; both sample the column at pixel centres (sarracen's only convention without
``exact``; dvr-gl averages a particle over the pixels only below :data:`..particles.SUBPIXEL_RADIUS` pixels,
and the table counts those).  Each is judged against the exact column at the pixel centres: the footprint
from a float64 table of 200001 entries in ``q = rho^2 / (2h)^2`` (1e-11 of its peak between entries), summed
in float64.  The error is the RMS over the image over the exact column's peak.

dvr-gl renders the pre-classified X-ray of the density through ``sigma = s rho`` with ``s`` such that the
largest optical depth is 1e-3, so the column is ``-log(1 - alpha) / s`` (float32 alpha: 1e-7 relative).
Frames are timed after a warm-up (the particles uploaded, numba's cached loops loaded); sarracen's after its
numba compile (every process compiles it: minutes on a busy machine), in a persistent worker of the peers'
interpreter (:mod:`.sarracen_worker`), one frame of each in turn.
"""

from __future__ import annotations

import functools
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PARTICLES = (10 ** 4, 10 ** 5, 10 ** 6)
PEAK_DEPTH = 1e-3  # the largest optical depth of dvr-gl's X-ray: alpha ~ tau, read back to float32 precision
COLUMNS = [("particles", "particles", ",d"), ("size", "image", ""), ("subpixel", "dvr-gl sub-pixel", ",d"),
           ("dvrgl_ms", "dvr-gl ms", ".0f"), ("dvrgl_error", "dvr-gl RMS / peak", ".1e"),
           ("sarracen_ms", "sarracen ms", ".0f"), ("sarracen_error", "sarracen RMS / peak", ".1e"),
           ("ratio", "sarracen / dvr-gl", ".1f")]
WORKER = Path(__file__).with_name("sarracen_worker.py")


@functools.lru_cache(maxsize=1)
def fine_table() -> np.ndarray:
    """``h^2 F`` at 200001 values of ``q`` in [0, 1] (float64)."""
    from ....fields import sph

    return sph.footprint(sph.SUPPORT * np.sqrt(np.linspace(0.0, 1.0, 200001)))


def window(particles) -> tuple[float, float, float, float]:
    """``(x0, y0, width)`` of the square window over the particles' positions, and its depth's top."""
    x = particles.positions
    lo, hi = x[:, :2].min(axis=0), x[:, :2].max(axis=0)
    width = float((hi - lo).max())
    centre = 0.5 * (lo + hi)
    return float(centre[0] - 0.5 * width), float(centre[1] - 0.5 * width), width, float(x[:, 2].max())


def exact_column(particles, size: int) -> np.ndarray:
    """The column density at the pixel centres, ``(size, size)`` float64, rows from the bottom (y up)."""
    from .. import column

    x0, y0, width, _ = window(particles)
    per = size / width
    x = particles.positions
    radius = 2.0 * particles.smoothing_lengths * per
    weights = (particles.masses / particles.smoothing_lengths ** 2)[:, None]
    args = ((x[:, 0] - x0) * per, (x[:, 1] - y0) * per, radius, np.ascontiguousarray(weights),
            np.zeros(len(x), bool), np.empty((len(x), 0)), np.ones(2), fine_table(), column.NO_BOX, size, size)
    return column.deposit(args, float(np.sum(radius ** 2)) * np.pi)[0]


def scene(particles, size: int, scale: float):
    """dvr-gl's scene: orthographic along -z over :func:`window`, the X-ray of ``sigma = scale rho``."""
    from ....scene.resolve import apply_overrides, parse_scene, resolve_scene

    x0, y0, width, top = window(particles)
    target = [x0 + 0.5 * width, y0 + 0.5 * width, 0.0]
    eye = [target[0], target[1], top + 4.0 * float(particles.smoothing_lengths.max()) + 1.0]
    vmax = float(particles.densities.max())
    keys = {"renderer.name": "splatting", "renderer.classification": "pre", "renderer.compositing": "xray",
            "renderer.shading.enabled": False, "image.width": size, "image.height": size,
            "camera.projection": "orthographic", "camera.view_height": width, "camera.eye": eye,
            "camera.target": target, "camera.up": [0.0, 1.0, 0.0],
            "transfer_function.points": [[0.0, 1, 1, 1, 0.0], [vmax, 1, 1, 1, scale * vmax]],
            "transfer_function.opacity_model": "extinction"}
    # the value range (the SPH sum at every particle: minutes at 10^6) enters neither the X-ray nor this
    # transfer function: set from the densities, as the resolved scene needs one
    particles.__dict__.setdefault("value_range", (0.0, vmax))
    out = resolve_scene(parse_scene(apply_overrides({}, keys), "dvr bench splatting --peers"), field=particles)
    forward, right, up = out.camera.basis()
    assert np.allclose(right, (1, 0, 0)) and np.allclose(up, (0, 1, 0)), "the view must look along -z, x right"
    return out


def error(image: np.ndarray, exact: np.ndarray) -> float:
    return float(np.sqrt(np.mean((image - exact) ** 2)) / exact.max())


class Sarracen:
    """The peers' interpreter running :mod:`.sarracen_worker`."""

    def __init__(self, python: str):
        try:
            self.process = subprocess.Popen([python, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                            text=True)
        except OSError as e:
            from ....errors import DvrError

            raise DvrError(f"cannot run the peers' interpreter {python}: {e.strerror or e}; pass --peers-python "
                           f"or make .venv-peers (benchmarks/peers-requirements.txt)") from None

    def frame(self, particles_file: Path, size: int, out: Path) -> tuple[float, np.ndarray]:
        self.process.stdin.write(json.dumps({"particles": str(particles_file), "size": size, "out": str(out)}) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            from ....errors import DvrError

            raise DvrError("the sarracen worker stopped (is sarracen installed in the peers' environment? "
                           "pip install -r benchmarks/peers-requirements.txt)")
        return json.loads(line)["seconds"], np.load(out)

    def close(self):
        self.process.stdin.close()
        self.process.wait()


def run(counts, size: int, repeat: int, python: str | None, progress=print) -> list[dict]:
    """The table's rows: per particle count, dvr-gl's and sarracen's frames in turn (medians of ``repeat``)."""
    from ....fields.particles import plummer_sphere
    from ... import create_renderer
    from ..particles import SUBPIXEL_RADIUS

    rows = []
    peer = Sarracen(python) if python else None
    renderer = create_renderer("splatting")
    try:
        with tempfile.TemporaryDirectory() as folder:
            for n in counts:
                particles = plummer_sphere(n)
                exact = exact_column(particles, size)
                x0, y0, width, _ = window(particles)
                path = Path(folder) / f"plummer-{n}.npz"
                x = particles.positions
                np.savez(path, x=x[:, 0], y=x[:, 1], z=x[:, 2], h=particles.smoothing_lengths, m=particles.masses,
                         rho=particles.densities, x0=x0, y0=y0, width=width)
                scale = PEAK_DEPTH / exact.max()
                case = scene(particles, size, scale)
                renderer.render(case)  # warm-up: the particles uploaded, the compiled loops loaded
                ours, theirs, image, peer_image = [], [], None, None
                for _ in range(repeat):
                    forget_views(renderer)  # whole frames: the projection too, as a new view's
                    image = renderer.render(case)
                    ours.append(renderer.stats["seconds"])
                    if peer:
                        seconds, peer_image = peer.frame(path, size, Path(folder) / "column.npy")
                        theirs.append(seconds)
                column = -np.log1p(-image[::-1, :, 3].astype(np.float64)) / scale
                row = {"particles": n, "size": f"{size}x{size}", "dvrgl_ms": 1e3 * statistics.median(ours),
                       "dvrgl_error": error(column, exact),
                       "subpixel": int((2.0 * particles.smoothing_lengths * size / width < SUBPIXEL_RADIUS).sum())}
                if peer:
                    row.update(sarracen_ms=1e3 * statistics.median(theirs), sarracen_error=error(peer_image, exact))
                    row["ratio"] = row["sarracen_ms"] / row["dvrgl_ms"]
                rows.append(row)
                if progress:
                    progress(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
    finally:
        renderer.close()
        if peer:
            peer.close()
    return rows


def forget_views(renderer):
    """Drop what the renderer's particle splats keep of the last view (:meth:`.ParticleSplats.cached_view`)."""
    for _, value in renderer._cache.values():
        if hasattr(value, "forget_view"):
            value.forget_view()


def default_python() -> str | None:
    path = Path(".venv-peers") / "bin" / "python"
    return str(path) if path.exists() else None


if __name__ == "__main__":  # a quick look: python -m dvr_gl.renderers.splatting.bench.peers N SIZE
    run([int(sys.argv[1])], int(sys.argv[2]), 1, default_python())
