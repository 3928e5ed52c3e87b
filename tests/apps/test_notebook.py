"""examples/quickstart.ipynb runs in a Jupyter kernel, and ``dvr_gl.render(numpy_array)`` shows a centred
picture inline.

Executed with nbclient and ipykernel (the optional extra ``notebook``, part of ``test``; skipped,
saying why, without them): every code cell runs without an error, and the first image the notebook
displays (IPython's PNG output of :meth:`dvr_gl.Image._repr_png_`) is the 256 x 256 picture of the
test array, its material centred: the centroid of its brightness within 3 % of the image's width of
the centre (measured: 0.1 % and 0.9 %; the two blobs lie on the volume's central axis and the camera
aims at the box's centre).
"""

from __future__ import annotations

import base64

import numpy as np
import pytest

from conftest import REPO

NOTEBOOK = REPO / "examples" / "quickstart.ipynb"


@pytest.fixture(scope="module")
def executed():
    nbformat = pytest.importorskip("nbformat", reason="nbformat/nbclient/ipykernel: pip install 'dvr-gl[notebook]'")
    nbclient = pytest.importorskip("nbclient", reason="nbclient: pip install 'dvr-gl[notebook]'")
    pytest.importorskip("ipykernel", reason="ipykernel: pip install 'dvr-gl[notebook]'")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    client.execute()
    return notebook


def _png_outputs(notebook):
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            if "image/png" in data:
                yield base64.b64decode(data["image/png"])


def test_every_cell_runs(executed):
    code = [c for c in executed.cells if c.cell_type == "code"]
    assert code and all(c.get("execution_count") for c in code)
    errors = [o for c in code for o in c.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors, errors


def test_render_of_an_array_shows_a_centred_picture(executed, tmp_path):
    from dvr_gl.image import read_image

    pngs = list(_png_outputs(executed))
    assert len(pngs) >= 4   # the array, its MIP, the demo scene, the scene on the array
    path = tmp_path / "first.png"
    path.write_bytes(pngs[0])
    pixels = read_image(path)
    assert pixels.shape[:2] == (256, 256)
    brightness = pixels[..., :3].mean(axis=-1)
    assert brightness.max() > 0.2
    rows, cols = np.indices(brightness.shape)
    weight = brightness / brightness.sum()
    centroid = np.array([(weight * cols).sum(), (weight * rows).sum()])
    assert np.all(np.abs(centroid - 127.5) <= 0.03 * 256), centroid


def test_the_refusal_prints_one_line(executed):
    printed = [o["text"] for c in executed.cells for o in c.get("outputs", []) if o.get("output_type") == "stream"]
    assert any("slicing3d does not support renderer.compositing = 'mip'" in t for t in printed)


def test_the_notebook_is_committed_with_its_pictures():
    """Read online (GitHub renders the file as it is), the notebook shows its pictures: the committed file
    holds each code cell's outputs, at least the four images, and stays small (small images: under 200 kB)."""
    import json

    notebook = json.loads(NOTEBOOK.read_text())
    code = [c for c in notebook["cells"] if c["cell_type"] == "code"]
    assert all(c.get("execution_count") for c in code)
    pictures = [o for c in code for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(pictures) >= 4 and NOTEBOOK.stat().st_size < 200_000
