"""``dvr bench cells``'s flags name the shared meshes without importing the harness (``dvr`` builds every
bench's flags on every command); the names are the harness's list."""

from dvr_gl.bench.datasets import MESHES
from dvr_gl.renderers.projected_tetrahedra.bench import MESH_NAMES


def test_the_flags_name_the_shared_meshes():
    assert MESH_NAMES == tuple(MESHES)
