"""VTK's ``vtkProjectedTetrahedraMapper`` frames on demand, for ``dvr bench cells`` to interleave with
dvr-gl's (A B A B ...: both share the machine's drift, which on a shared machine moves a frame by
tens of percent between minutes).

Run by the peers' interpreter (no dvr-gl there: ``dvr_gl/bench/peer_worker.py`` is loaded from its
file, as ``dvr bench peers`` runs it)::

    PYTHON vtk_frames.py SCENE.json SIZE

``SCENE.json`` is the worker's scene for ``vtk-pt`` (the ``.vtu``, transfer function, unit distance,
camera, clipping range).  After one untimed frame it prints ``ready``; then each line read on stdin
renders one frame (VTK sorts its cells again: the camera marked modified) and prints its seconds.
"""

from __future__ import annotations

import importlib.util
import json
import sys
import time
from pathlib import Path

WORKER = Path(__file__).resolve().parents[3] / "bench" / "peer_worker.py"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    spec = importlib.util.spec_from_file_location("peer_worker", WORKER)
    worker = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(worker)
    size = int(argv[1])
    peer = worker.VtkTetraPeer(json.loads(Path(argv[0]).read_text()), (size, size))
    try:
        peer.render()  # the upload and first sort: untimed
        print("ready", flush=True)
        for _ in sys.stdin:
            start = time.perf_counter()
            peer.render()
            print(time.perf_counter() - start, flush=True)
    finally:
        peer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
