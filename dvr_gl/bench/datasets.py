"""The shared datasets (``../shared/data``) as the benches read them: regular grids with the scene
overrides that show them, and the tetrahedral meshes with a transfer function over their scalar.

Several benches measure on the same lists, whichever renderer they measure, so the lists live once,
in the harness: a renderer's bench and a cross-renderer one name a dataset the same way.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..fields import diagonal

# CT data in Hounsfield units stored as unsigned (the files' rescale intercept)
_HU = {"transfer_function.rescale_intercept": -1024.0}
_HU_BONE = {"transfer_function.preset": "ct-bone-ivory", **_HU}

#: Every regular dataset: name, file under the data folder, scene overrides (default transfer functions).
REGULAR = [
    ("bucky", "regular/bucky.nhdr", {}), ("nucleon", "regular/nucleon.nhdr", {}),
    ("neghip", "regular/neghip.nhdr", {}), ("ironProt", "regular/ironProt.nhdr", {}),
    ("headsq", "regular/headsq_quarter.nhdr", _HU_BONE), ("hydrogen", "regular/hydrogen_atom.nhdr", {}),
    ("brainsmall", "regular/brainsmall.nhdr", {}), ("lobster", "regular/lobster.nhdr", {}),
    ("CThead", "regular/cthead.nhdr", {**_HU_BONE, "camera.up": [0, 0, -1]}),
    ("MNI152", "regular/MNI152_2009_template.nii.gz", {}),
]

#: Datasets with a transfer function chosen to be hard or easy to skip (``dvr bench accel``, ``dvr bench
#: tradeoff``): name, file under the data folder, scene overrides (transfer function, camera).
STUDIES = [
    ("CThead, bone", "regular/cthead.nhdr", {"transfer_function.preset": "ct-bone-ivory", **_HU,
                                             "camera.up": [0, 0, -1]}),
    ("CThead, skin", "regular/cthead.nhdr", {"transfer_function.preset": "ct-skin", **_HU, "camera.up": [0, 0, -1]}),
    ("CT bunny, bone", "large/bunny_ct.nhdr", {"transfer_function.preset": "ct-bone-ivory", **_HU}),
    ("lobster, shell", "regular/lobster.nhdr", {"transfer_function.points": [
        [0, 0, 0, 0, 0], [100, 0.9, 0.4, 0.2, 0], [120, 0.9, 0.4, 0.2, 0.6], [140, 0.9, 0.5, 0.3, 0],
        [255, 0, 0, 0, 0]]}),
    ("hydrogen, narrow shell", "regular/hydrogen_atom.nhdr", {"transfer_function.points": [
        [0, 0, 0, 0, 0], [55, 0.2, 0.6, 1, 0], [60, 0.2, 0.6, 1, 0.5], [65, 0.2, 0.6, 1, 0], [255, 0, 0, 0, 0]]}),
]

#: The tetrahedral meshes: name: (file under the data folder, scalar array or None for the reader's default).
MESHES = {
    "bluntfin": ("unstructured/bluntfin_tets.vtk", "density"),
    "comb": ("unstructured/comb_tets.vtk", "density"),
    "post": ("unstructured/post_tets.vtk", "q4_energy"),
    "jaw": ("unstructured/kiefer_jaw_tet10.vtu", None),
    "notch": ("unstructured/notch_stress.vtk", None),
    "tetraMesh": ("unstructured/tetraMesh.vtk", None),
}
COLOURS = ((0.27, 0.0, 0.33, 0.0), (0.23, 0.32, 0.55, 0.15), (0.13, 0.57, 0.55, 0.3), (0.37, 0.79, 0.38, 0.5),
           (0.99, 0.91, 0.14, 0.8))  # viridis at the quintiles, alpha 0 to 0.8


def shared_scenes(data_dir: Path, only: str | None = None, datasets=REGULAR):
    """The datasets found (``(name, overrides)``; ``only``: names containing it) and notes on those left out."""
    scenes, notes = [], []
    for name, path, overrides in datasets:
        if only and only not in name:
            continue
        if not (data_dir / path).exists():
            notes.append(f"{name}: {data_dir / path} not found, left out")
            continue
        scenes.append((name, {"volume.path": str(data_dir / path), **overrides}))
    return scenes, notes


def transfer_function(values: np.ndarray) -> list[list[float]]:
    """Control points at the scalar's quintiles (strictly increasing), colours of viridis, alpha 0..0.8."""
    q = np.quantile(values, np.linspace(0.0, 1.0, len(COLOURS)))
    span = max(float(q[-1] - q[0]), 1e-30)
    for i in range(1, len(q)):  # repeated quantiles (a constant stretch): nudge apart
        q[i] = max(q[i], q[i - 1] + 1e-6 * span)
    return [[float(v), *c] for v, c in zip(q, COLOURS)]


def shared_mesh(name: str, data_dir: Path) -> tuple[dict, object]:
    """Shared mesh ``name`` of :data:`MESHES` read from ``data_dir``: its scene keys (:func:`mesh_scene_keys`)
    and the mesh field, read once for every view a bench takes of it."""
    from ..scene.resolve import load_scene

    source, array = MESHES[name]
    path = Path(data_dir) / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    return mesh_scene_keys(path, array, mesh), mesh


def mesh_scene_keys(path: Path, array: str | None, mesh) -> dict:
    """A mesh's scene keys: its file and array, the quintile transfer function, alpha per a tenth of its
    diagonal (``transfer_function.unit_distance``), and a converged reference to 1e-5."""
    keys = {"volume.path": str(path), "transfer_function.points": transfer_function(mesh.values),
            "transfer_function.unit_distance": diagonal(mesh) / 10.0, "renderer.converged_tolerance": 1e-5}
    if array:
        keys["volume.array"] = array
    return keys
