"""Hash the images of every registered renderer, to show that a restructuring changes no pixel.

For each renderer: the conformance suite's closed-form scenes (``tests/closed_forms.py``) in every mode and
view it declares, its oracle scene (the 16^3 phantom), and every value of every trade-off family it declares
(:mod:`dvr_gl.scene.sweeps`) on that phantom.  Each image's float32 bytes are hashed (SHA-256); the output is one
JSON object, ``{case: hash}``.  Run it before and after a change and compare the two files::

    python benchmarks/image_hashes.py > before.json      # on the old commit
    python benchmarks/image_hashes.py > after.json       # on the new one
    python benchmarks/image_hashes.py --compare before.json after.json

A one-off check (issue 41's "every image bit-identical"), not part of CI: the conformance tests judge images
against references with tolerances; this asks for identity.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

PHANTOM = {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20, "image.height": 20,
           "transfer_function.points": [[0, 0.2, 0.4, 0.9, 0.05], [1, 1.0, 0.8, 0.3, 0.4]],
           "renderer.ert_threshold": 1.0}


def _digest(image) -> str:
    return hashlib.sha256(np.ascontiguousarray(image, np.float32).tobytes()).hexdigest()[:16]


def cases(tmp):
    """(case id, scene thunk) for every renderer, closed form, mode, view and sweep value."""
    from closed_forms import CLOSED_FORMS, VIEWS, own_filter
    from dvr_gl.renderers import registry
    from dvr_gl.scene.resolve import load_scene

    for name, plugin in registry.plugins().items():
        if plugin.reference:
            continue   # the CPU judges: slow, and no restructuring of the GL code touches them
        kinds = sorted({cf.kind for cf in CLOSED_FORMS.values()})
        kinds = kinds if plugin.data_kinds is None else [k for k in kinds if k in plugin.data_kinds]
        modes = plugin.choices("compositing")
        views = [v for v in VIEWS if v in plugin.projections]
        for cf in CLOSED_FORMS.values():
            for mode in (m for m in cf.modes if m in modes and cf.kind in kinds):
                for view in views:
                    yield name, f"{name}/{cf.name}/{mode}/{view}", (lambda cf=cf, m=mode, v=view, n=name:
                                                                     cf.scene(tmp, m, v, n))
        if plugin.data_kinds is not None and "grid" not in plugin.data_kinds:
            continue
        for mode in modes:
            for view in views:
                keys = {**PHANTOM, "renderer.name": name, "renderer.compositing": mode, **own_filter(name, mode),
                        **VIEWS[view]}
                yield name, f"{name}/phantom/{mode}/{view}", (lambda k=keys: load_scene(None, k))
        view = views[0]
        for family in plugin.sweeps:
            for value in family.values:
                keys = {**PHANTOM, "renderer.name": name, **own_filter(name), **VIEWS[view], **dict(family.fixed),
                        family.key: value}
                yield name, f"{name}/sweep/{family.label}/{value}", (lambda k=keys: load_scene(None, k))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = parser.parse_args(argv)
    if args.compare:
        before, after = (json.loads(Path(p).read_text()) for p in args.compare)
        changed = sorted(k for k in before if k in after and before[k] != after[k])
        missing = sorted(set(before) ^ set(after))
        print(f"{len(before)} cases before, {len(after)} after; {len(changed)} differ; {len(missing)} in one only")
        for k in changed + missing:
            print("  ", k)
        return 1 if changed or missing else 0
    from dvr_gl.errors import DvrError
    from dvr_gl.renderers import create_renderer

    out, opened = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, case, scene in cases(Path(tmp)):
            try:
                s = scene()
                r = opened.setdefault(name, create_renderer(name))
                out[case] = _digest(r.render(s))
            except DvrError as e:   # a combination the renderer refuses: the refusal is the result
                out[case] = "refused: " + str(e).splitlines()[0][:80]
    for r in opened.values():
        r.close()
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
