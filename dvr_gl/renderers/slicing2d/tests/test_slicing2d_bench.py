"""``dvr bench slicing``: the 2D stacks' image jumps where the stack switches; view-aligned slices do not."""

from dvr_gl.apps.cli import main


def test_bench_slicing_shows_the_stack_switch(tmp_path, capsys):
    args = ["bench", "slicing", "--size", "24", "--volume-size", "16", "--pictures", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    sweep, jump = out.split("image change")
    jumps = {float(line.split()[0]): [float(x) for x in line.split()[1:]] for line in jump.splitlines()
             if line.startswith(("30 ", "45 "))}
    stacks = {line.split()[0]: line.split()[1] for line in sweep.splitlines() if line[:3] in ("44 ", "46 ")}
    assert stacks == {"44": "y", "46": "x"}
    # the 2D stack's image jumps where it switches; view-aligned slices do not care
    assert jumps[45.0][0] > 5 * jumps[30.0][0]
    assert jumps[45.0][2] < 3 * jumps[30.0][2]
    for name in ("slicing_sweep.png", "slicing_jump.png"):
        assert (tmp_path / name).stat().st_size > 0
    before = (tmp_path / "slicing_jump.png").read_bytes()
    assert main(args) == 1                                   # no --overwrite: refused before any work
    assert "exists; pass --overwrite" in capsys.readouterr().err
    assert (tmp_path / "slicing_jump.png").read_bytes() == before
