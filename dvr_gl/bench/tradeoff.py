"""``dvr bench tradeoff``: error against the converged reference versus frame time.

For every registered renderer and every family of accuracy settings it declares
(its plugin's ``sweeps``, :mod:`dvr_gl.scene.sweeps`: one setting varied, the others at
the scene's values), render, time the frame (median of ``repeat`` after a
warm-up; the read-back finishes GL) and measure the error against the converged
reference of the scene as given: RMS, maximum and PSNR through OpenImageIO, and
the mean FLIP error (NVIDIA's perceptual difference for rendered images, from
the optional ``flip-evaluator`` package) of the two images as displayed (over the
background, sRGB).  The truth is one image for every row: the scene's own
reconstruction filter and the exact transfer function, so a filter or a
classification that differs from the model shows its bias as an error floor.

Rows on the Pareto front (no other row is both faster and more accurate) are
marked.  A renderer joins the bench by declaring its sweeps in its plugin.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..errors import SceneError
from ..image import compare_images, composite_over
from ..reference.converged import ConvergedReference
from ..renderers import create_renderer, registry
from ..transfer_function import linear_to_srgb
from . import converged, median_seconds, picks
from .datasets import STUDIES


def sweeps(renderers=None, kind: str | None = None, projection: str | None = None) -> dict:
    """renderer -> its trade-off families (:mod:`dvr_gl.scene.sweeps`), as its plugin declares them: every
    registered renderer with a sweep (``renderers``: only these; ``kind``, ``projection``: only those
    rendering that kind of data in that projection)."""
    out = {name: tuple(f for f in p.sweeps if f.applies_to(kind)) for name, p in registry.plugins().items()
           if p.sweeps and (not renderers or name in renderers)
           and (kind is None or p.data_kinds is None or kind in p.data_kinds)
           and (projection is None or projection in p.projections)}
    return {name: families for name, families in out.items() if families}


COLUMNS = [("renderer", "renderer", ""), ("family", "setting family", ""), ("setting", "setting", ""),
           ("ms", "frame ms", ".1f"), ("rms", "RMS", ".2e"), ("max", "max", ".2e"), ("psnr", "PSNR dB", ".1f"),
           ("flip", "FLIP", ".4f"), ("pareto", "front", "")]


def flip_error(image: np.ndarray, truth: np.ndarray, background) -> float | None:
    """Mean FLIP error of the two images as displayed (over ``background``, sRGB, 8-bit range);
    None without the optional ``flip-evaluator`` package."""
    try:
        import flip_evaluator
    except ImportError:
        return None
    shown = [linear_to_srgb(composite_over(x, background)[..., :3]).astype(np.float32) for x in (image, truth)]
    _, mean, _ = flip_evaluator.evaluate(shown[1], shown[0], "LDR", applyMagma=False)
    return float(mean)


def converged_truth(scene, tolerance: float = 1e-4) -> np.ndarray:
    """The converged reference of ``scene`` as float32 (its error budget per pixel: ``tolerance``)."""
    truth_scene = scene.with_renderer(converged_tolerance=tolerance)
    return converged(ConvergedReference(truth_scene), float64=True).astype(np.float32)


def cases(renderers=None, kind: str | None = None, projection: str | None = None):
    """(renderer, family, value) for every setting to measure."""
    for name, families in sweeps(renderers, kind, projection).items():
        for family in families:
            for value in family.values:
                yield name, family, value


def variant(scene, name: str, family, value):
    """``scene`` rendered by ``name`` with the family's fixed settings and ``key = value`` (renderer keys;
    a distance in voxels becomes world units where the scene resolves it)."""
    changes = {"name": name}
    for key, v in (*family.fixed, (family.key, value)):
        table, _, field = key.removeprefix("renderer.").partition(".")
        if field:  # a key of a table setting (renderer.scattering.method): the table with it replaced
            changes[table] = dataclasses.replace(changes.get(table, getattr(scene.renderer, table)), **{field: v})
        else:
            changes[table] = v
    return scene.with_renderer(**changes)


def run(scene, repeat: int = 5, renderers=None, truth=None, progress=None, scene_name: str = "scene"):
    """Rows (one per renderer x setting) and notes (settings a renderer refused)."""
    truth = converged_truth(scene) if truth is None else truth
    rows, refused, open_renderers = [], {}, {}
    try:
        for name, family, value in cases(renderers, getattr(scene.field, "kind", None), scene.camera.projection):
            if not family.applies_to_scene(scene):
                continue
            case = variant(scene, name, family, value)
            renderer = open_renderers.get(name) or open_renderers.setdefault(name, create_renderer(name))
            try:
                ms = 1e3 * median_seconds(renderer, case, repeat)
            except SceneError as exc:
                refused.setdefault((name, str(exc)), []).append(f"{family.label} {_text(value)}")
                continue
            image = renderer.render(case)
            err = compare_images(image, truth)
            rows.append({"scene": scene_name, "renderer": name, "family": family.label, "key": family.key,
                         "setting": _text(value), "value": value, "ms": ms, "rms": err["rms"], "max": err["max"],
                         "psnr": err["psnr"], "mean": err["mean"],
                         "flip": flip_error(image, truth, scene.image.background)})
            if progress:
                progress(rows[-1])
    finally:
        for r in open_renderers.values():
            r.close()
    mark_pareto(rows)
    kind, projection = getattr(scene.field, "kind", None), scene.camera.projection
    other = [name for name in sweeps(renderers) if name not in sweeps(renderers, kind, projection)]
    skipped = [f"no sweep for {kind} data in {projection} views: {', '.join(other)}"] if other else []
    return rows, skipped + _refusal_notes(refused, rows)


def _refusal_notes(refused: dict, rows: list[dict]) -> list[str]:
    """One line per renderer and reason: what it refused (all of it, if it rendered nothing)."""
    rendered = {r["renderer"] for r in rows}
    notes, whole = [], set()
    for (name, reason), what in refused.items():
        if name in rendered:
            notes.append(f"{name}: refused {', '.join(what)} ({reason})")
        elif name not in whole:  # nothing rendered: its first reason says why
            whole.add(name)
            notes.append(f"{name}: refused this scene ({reason})")
    return notes


def _text(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def mark_pareto(rows: list[dict], error: str = "rms") -> list[dict]:
    """Mark (``pareto = "*"``) the rows no other row beats in both time and error."""
    best = math.inf
    for row in sorted(rows, key=lambda r: (r["ms"], r[error])):
        on_front = row[error] < best
        row["pareto"] = "*" if on_front else ""
        best = min(best, row[error])
    return [r for r in rows if r["pareto"]]


TOLERANCES = (1e-2, 3e-3, 1e-3)
TOLERANCE_COLUMNS = [("tolerance", "tolerance", "g"), ("choice", "chosen (raycast)", ""),
                     ("predicted", "predicted RMS", ".2e"), ("rms", "measured RMS", ".2e"), ("met", "met", ""),
                     ("ms", "frame ms", ".1f"), ("front", "front: fastest meeting it", ""),
                     ("front_ms", "its ms", ".1f")]


def tolerance_check(scene, rows: list[dict], truth, repeat: int = 5, tolerances=TOLERANCES):
    """For each tolerance: what the error model chooses, its measured error and frame time, and the
    fastest measured row (the front) that meets it.  Returns (rows, note or None)."""
    import importlib

    from ..scene.plugin import load

    out = []
    kind = getattr(scene.field, "kind", "grid")
    if kind != "grid":
        return out, (f"--tolerance not checked: it chooses the ray caster's settings, and the ray caster renders "
                     f"grids, not {kind}")
    name = picks.renderers("tolerance")[0]  # the renderer that declares renderer.tolerance (the ray caster)
    # its error model is beside its resolve hook (tolerance -> settings): check_tolerance, sampling_model, apply
    model = importlib.import_module(load(registry.plugin(name).resolve).__module__)
    scene = scene.with_renderer(name=name)
    try:
        model.check_tolerance(scene, tolerances[0])
    except SceneError as exc:
        return out, f"--tolerance not checked: {exc}"
    bandwidths = model.sampling_model(scene)
    with create_renderer(name) as renderer:
        for e in tolerances:
            chosen, choice = model.apply(scene, e, bandwidths)
            ms = 1e3 * median_seconds(renderer, chosen, repeat)
            rms = compare_images(renderer.render(chosen), truth)["rms"]
            best = cheapest_meeting(rows, e)
            voxels = choice.sample_distance / scene.field.sample_spacing
            out.append({"scene": rows[0]["scene"] if rows else "scene", "tolerance": e,
                        "choice": f"{choice.classification} {voxels:.3g} vox",
                        "predicted": choice.predicted_error, "rms": rms, "met": "yes" if rms <= e else "NO", "ms": ms,
                        "front": f"{best['renderer']} {best['family']} {best['setting']}" if best else "none",
                        "front_ms": best["ms"] if best else None})
    return out, None


def cheapest_meeting(rows: list[dict], tolerance: float, error: str = "rms") -> dict | None:
    """The fastest measured row whose error is at most ``tolerance`` (None if none is)."""
    meeting = [r for r in rows if r[error] <= tolerance]
    return min(meeting, key=lambda r: r["ms"]) if meeting else None


# The shared datasets (../shared/data) as scenes: four of ``dvr bench accel``'s (name, file, overrides).
DATASETS = [d for name in ("CThead, bone", "lobster, shell", "hydrogen, narrow shell", "CT bunny, bone")
            for d in STUDIES if d[0] == name]


def csv_text(rows: list[dict]) -> str:
    """The rows as CSV (one header line; the columns of the JSON records)."""
    import csv
    import io

    keys = ["scene", "renderer", "family", "key", "setting", "ms", "rms", "max", "mean", "psnr", "flip", "pareto"]
    out = io.StringIO()
    writer = csv.DictWriter(out, keys, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row.get(k) is None else row[k]) for k in keys})
    return out.getvalue()


def json_text(rows: list[dict], meta: dict) -> str:
    import json

    def clean(v):
        return None if isinstance(v, float) and not math.isfinite(v) else v

    records = [{k: clean(v) for k, v in row.items()} for row in rows]
    return json.dumps({"meta": meta, "rows": records}, indent=1) + "\n"
