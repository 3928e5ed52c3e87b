"""``dvr bench channels``: what several fields cost the ray caster against one field's frame.

Cases: one field (the single-field path), 1 to 4 channels on one grid (one texture, up to four channels), and
two fields on separate grids (two textures: the second shifted by half a voxel, so it is no longer the first's
grid).  Each channel a Shepp-Logan phantom variant with its own transfer function.  Frames interleaved: each
round renders every case once, ``repeat`` rounds after a warm-up round; the median of the draw-to-glFinish times
(textures uploaded, read-back excluded), and its ratio to one field's.
"""

from __future__ import annotations

import statistics

import numpy as np

from ....api import scene_of
from ....fields.grid import Volume
from ....fields.layers import FieldSet, Member
from ....phantoms import shepp_logan
from ....transfer_function import TransferFunction
from ..renderer import RayCastRenderer

COLOURS = ((0.9, 0.2, 0.8), (0.2, 0.9, 0.2), (0.2, 0.8, 0.9), (0.9, 0.6, 0.1))
COLUMNS = [("case", "case", ""), ("textures", "textures", "d"), ("ms", "frame ms (median)", ".1f"),
           ("ratio", "of one field", ".2f")]


def _channel(base: np.ndarray, k: int) -> np.ndarray:
    """Channel k: the phantom, its values bent differently per channel (the same structures, other densities)."""
    return np.ascontiguousarray(base ** (1.0 + 0.5 * k), dtype=np.float32)


def _tf(k: int) -> TransferFunction:
    r, g, b = COLOURS[k]
    return TransferFunction([[0.0, r, g, b, 0.0], [0.15, r, g, b, 0.0], [0.5, r, g, b, 0.3], [1.0, r, g, b, 0.6]])


def cases(size: int) -> list:
    """(label, data, transfer functions) of every case over a ``size``^3 phantom."""
    base = np.clip(shepp_logan(size).astype(np.float32), 0.0, 1.0)
    vols = [Volume(_channel(base, k), spacing=(1, 1, 1)) for k in range(4)]
    shifted = Volume(vols[1].data, spacing=(1, 1, 1), origin=(0.5, 0.5, 0.5))
    out = [("one field", vols[0], _tf(0))]
    for n in range(1, 5):
        out.append((f"{n} channel{'s' * (n > 1)}, one grid", FieldSet(tuple(Member(v) for v in vols[:n])),
                    [_tf(k) for k in range(n)]))
    out.append(("2 fields, separate grids", FieldSet((Member(vols[0]), Member(shifted))), [_tf(0), _tf(1)]))
    return out


def file_cases(path: str) -> list:
    """The cases of a multichannel file (``dvr_gl.io.load_field``): its first channel alone (the single-field
    path), and its first 1 to 4 channels on their grid, each with its default channel transfer function."""
    from ....io import load_field
    from ....transfer_function import channel_transfer_function

    field = load_field(path)
    members = getattr(field, "members", None)
    if not members:
        raise SystemExit(f"{path}: one channel; dvr bench channels needs a file of several")
    tfs = [channel_transfer_function(k, m.field.value_range) for k, m in enumerate(members)]
    out = [("one field (channel 0)", members[0].field, tfs[0])]
    for n in range(1, min(len(members), 4) + 1):
        out.append((f"{n} channel{'s' * (n > 1)}, one grid", FieldSet(tuple(members[:n])), tfs[:n]))
    return out


def run(size: int = 128, image: int = 512, repeat: int = 5, path: str | None = None) -> list[dict]:
    scenes = []
    for label, data, tfs in (file_cases(path) if path else cases(size)):
        scenes.append((label, scene_of(data, transfer_function=tfs, renderer="raycast", size=(image, image),
                                       acceleration="off")))
    times = {label: [] for label, _ in scenes}
    textures = {}
    with RayCastRenderer() as renderer:
        for round_ in range(repeat + 1):  # round 0: the warm-up (programs, textures)
            for label, scene in scenes:
                renderer.render(scene)
                textures[label] = renderer.stats.get("field_textures", 1)
                if round_:
                    times[label].append(renderer.stats["gpu_seconds"])
    one = statistics.median(times[scenes[0][0]])
    return [{"case": label, "textures": textures[label], "ms": 1e3 * statistics.median(times[label]),
             "ratio": statistics.median(times[label]) / one} for label, _ in scenes]
