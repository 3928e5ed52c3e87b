"""A longer fuzzing run of the scene parser and ``dvr render`` than the tests' (issue 14, item 5).

    python benchmarks/fuzz_scenes.py [--examples 2000] [--seed 0]

Targets: ``scene`` (random scene dicts from the schema, loaded), ``render`` (the same, rendered at
16x16 on the CPU reference; a third of the examples), ``render-own`` (on the scene's own renderer, the
GL ones included; a tenth) and ``cli`` (random ``dvr render`` flag lists on a
tiny demo; a tenth).  Prints a table (target, examples, user errors, scenes loaded or rendered, other
exceptions) and each distinct finding (an exception other than a user error) with one example input.
The strategies are the tests' (``tests/scene_fuzzing.py``); docs/robustness.md has the last run.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, seed, settings

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from dvr_gl.apps.cli import build_parser  # noqa: E402
from scene_fuzzing import cli_argvs, cli_outcome, scene_dicts, scene_outcome  # noqa: E402


def run(name, strategy, outcome_of, examples: int, random_seed: int, findings: dict) -> collections.Counter:
    counts = collections.Counter()

    @seed(random_seed)
    @settings(max_examples=examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(strategy)
    def one(example):
        outcome, detail = outcome_of(example)
        counts[outcome] += 1
        if outcome == "other":
            key = (name, type(detail).__name__ if isinstance(detail, BaseException) else "exit",
                   str(detail)[:160])
            findings.setdefault(key, example)

    one()
    return counts


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", type=int, default=2000, help="scene examples (render and cli get a tenth)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    findings: dict = {}
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        np.save(folder / "small.npy", np.linspace(0, 1, 120, dtype=np.float32).reshape(6, 5, 4))
        (folder / "empty.raw").write_bytes(b"")
        files = {"small": folder / "small.npy", "folder": folder, "missing": folder / "absent.nrrd",
                 "empty": folder / "empty.raw"}
        out = folder / "o.png"
        targets = [
            ("scene", scene_dicts(files), scene_outcome, args.examples),
            ("render", scene_dicts(files), lambda raw: scene_outcome(raw, render=True), max(1, args.examples // 3)),
            ("render-own", scene_dicts(files), lambda raw: scene_outcome(raw, render="own"),
             max(1, args.examples // 10)),
            ("cli", cli_argvs(build_parser()),
             lambda a: cli_outcome(["render", "--demo", *a, "--set", "volume.size=8", "--size", "8", "--overwrite",
                                    "-o", str(out)]), max(1, args.examples // 10)),
        ]
        print("| target | examples | user errors | loaded / rendered / exit 0 | other exceptions | seconds |")
        print("|---|---:|---:|---:|---:|---:|")
        for name, strategy, outcome_of, n in targets:
            start = time.perf_counter()
            c = run(name, strategy, outcome_of, n, args.seed, findings)
            ok = c["loaded"] + c["rendered"] + c["ok"]
            print(f"| {name} | {sum(c.values())} | {c['user error']} | {ok} | {c['other']} | "
                  f"{time.perf_counter() - start:.0f} |", flush=True)
    print(f"\n{len(findings)} distinct findings")
    for (name, kind, text), example in findings.items():
        print(f"- {name}: {kind}: {text}\n    e.g. {example!r}"[:600])
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
