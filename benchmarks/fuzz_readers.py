"""Fuzz every volume reader for longer than CI does, and print what happened.

    python benchmarks/fuzz_readers.py [--examples 4000] [--seed 0] [--no-shared]

The same mutations as ``tests/io/test_fuzz_readers.py`` (``tests/fuzz_inputs.py``: byte and line
mutations of small generated files of every format, and of the real headers in
``../shared/data`` when that folder is there), drawn from a seeded ``random.Random`` and
spread evenly over the inputs.  Prints a table per reader (examples, user errors, volumes,
other exceptions) and each distinct finding: an exception other than a user error, a hang,
or a volume that is not valid.  Exits 1 if there was any finding.
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))  # the mutations are shared with the tests

from dvr_gl.bench import format_table  # noqa: E402
from fuzz_inputs import check_reader, mutate, seeds, shared_seeds, write_case  # noqa: E402


def run(inputs, examples: int, seed: int):
    counts: dict[str, Counter] = defaultdict(Counter)
    findings: dict[tuple, str] = {}
    rnd = random.Random(seed)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i in range(examples):
            case = inputs[i % len(inputs)]
            files, what = mutate(case, rnd)
            counts[case.reader]["examples"] += 1
            try:
                outcome = check_reader(write_case(folder, case, files), case)
            except BaseException as exc:  # noqa: BLE001 - every other outcome is a finding
                if isinstance(exc, KeyboardInterrupt):
                    raise
                outcome = "other exceptions"
                frame = traceback.extract_tb(exc.__traceback__)[-1]
                key = (case.reader, type(exc).__name__, frame.filename, frame.lineno)
                findings.setdefault(key, f"{case.main} ({what}): {type(exc).__name__}: {str(exc)[:120]} "
                                         f"at {Path(frame.filename).name}:{frame.lineno}")
            counts[case.reader][outcome] += 1
    return counts, findings


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=4000, help="mutated inputs in all")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-shared", action="store_true", help="only the generated inputs")
    args = parser.parse_args(argv)
    inputs = seeds()
    shared = REPO.parent / "shared" / "data"
    if not args.no_shared and (shared / "README.md").is_file():
        inputs += shared_seeds(shared)
    start = time.perf_counter()
    counts, findings = run(inputs, args.examples, args.seed)
    seconds = time.perf_counter() - start
    keys = ("examples", "user error", "volume", "other exceptions")
    rows = [{"reader": reader, **{k: counts[reader][k] for k in keys}} for reader in sorted(counts)]
    rows.append({"reader": "all", **{k: sum(counts[r][k] for r in counts) for k in keys}})
    columns = [("reader", "reader", "s"), ("examples", "examples", "d"), ("user error", "user errors", "d"),
               ("volume", "volumes", "d"), ("other exceptions", "other exceptions", "d")]
    print(format_table(rows, columns))
    print(f"\n{args.examples} examples over {len(inputs)} inputs in {seconds:.1f} s (seed {args.seed})")
    print(f"findings: {len(findings)}")
    for text in findings.values():
        print(f"  - {text}")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
