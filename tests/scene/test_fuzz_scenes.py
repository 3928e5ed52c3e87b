"""Fuzzing the scene parser and ``dvr render`` (issue 14, item 5): random scenes built from the schema and
random flag lists end in a user error or a scene that loads (renders, for a subset), never in another
exception.  A bounded, derandomized number of examples here; ``benchmarks/fuzz_scenes.py`` runs more."""

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings

from dvr_gl.apps.cli import build_parser
from scene_fuzzing import cli_argvs, cli_outcome, scene_dicts, scene_outcome

CI = settings(max_examples=100, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                     HealthCheck.data_too_large])


#: A scene that loads and renders: the hypothesis draws of a run may all be refusals (the draws are the same
#: in every run of one test file alone, but not after some other test files in the same process).
PLAIN = {"volume": {"demo": "marschner-lobb", "size": 12}}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Volumes a fuzzed volume.path may name: a small one, a folder, a missing file, an empty one (read
    under any volume.format the fuzzer picks; malformed files are the readers' fuzz tests' business)."""
    folder = tmp_path_factory.mktemp("fuzz")
    np.save(folder / "small.npy", np.linspace(0, 1, 6 * 5 * 4, dtype=np.float32).reshape(6, 5, 4))
    (folder / "empty.raw").write_bytes(b"")
    # transfer-function files (Slicer's .vp, ParaView's JSON) and a mesh, for transfer_function.file and
    # [[renderer.geometry]] (their own mutations are tests/scene/test_fuzz_transfer_functions.py's business)
    from test_fuzz_transfer_functions import SEEDS

    (folder / "tf.vp").write_bytes(SEEDS["bone.vp"])
    (folder / "tf.json").write_bytes(SEEDS["map.json"])
    (folder / "mesh.obj").write_text("v 0 0 0\nv 3 0 0\nv 0 3 0\nv 0 0 3\nf 1 2 3\nf 1 2 4\n")
    return {"small": folder / "small.npy", "folder": folder, "missing": folder / "absent.nrrd",
            "empty": folder / "empty.raw", "tf-vp": folder / "tf.vp", "tf-json": folder / "tf.json",
            "mesh": folder / "mesh.obj"}


def test_scenes_load_or_give_a_user_error(files):
    seen = set()

    @CI
    @given(scene_dicts(files))
    @example(PLAIN)  # the properties below need each outcome once, whatever the draws of a run
    def check(raw):
        outcome, exc = scene_outcome(raw)
        seen.add(outcome)
        assert outcome != "other", f"{type(exc).__name__}: {exc} for {raw!r}"
    check()
    assert seen == {"loaded", "user error"}  # the strategies reach past the parser, not only into its errors


def test_loaded_scenes_render_finite_pixels_in_range(files):
    """The CPU reference at 16x16: premultiplied pixels finite and in [0, 1] (1e-6 for float64 rounding)."""
    seen = set()

    @settings(CI, max_examples=25)
    @given(scene_dicts(files))
    @example(PLAIN)
    def check(raw):
        outcome, exc = scene_outcome(raw, render=True)
        seen.add(outcome)
        assert outcome != "other", f"{type(exc).__name__}: {exc} for {raw!r}"
    check()
    assert "rendered" in seen


def test_command_lines_exit_0_or_1_with_one_line(tmp_path):
    parser = build_parser()
    out = tmp_path / "o.png"

    seen = set()

    @settings(CI, max_examples=20)
    @given(cli_argvs(parser))
    def check(argv):
        outcome, err = cli_outcome(["render", "--demo", *argv, "--set", "volume.size=8", "--size", "8",
                                    "--overwrite", "-o", str(out)])
        seen.add(outcome)
        assert outcome != "other", f"{argv}: {err}"
    check()
    assert seen == {"ok", "user error"}
