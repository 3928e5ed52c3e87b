"""The README's two commands are the ones CI and users run."""

from conftest import REPO


def readme_commands():
    lines = (REPO / "README.md").read_text().splitlines()
    return [ln.strip() for ln in lines if ln.strip().startswith("python3 -m venv .venv && ")]


def test_readme_has_the_demo_and_test_commands():
    commands = readme_commands()
    assert any(c.endswith("dvr render --demo -o demo.png --overwrite") for c in commands)
    assert any("pytest" in c for c in commands)


def test_ci_runs_the_readme_test_command_verbatim():
    test_command = next(c for c in readme_commands() if "pytest" in c)
    ci = (REPO / ".ci" / "run").read_text().splitlines()
    assert test_command in [ln.strip() for ln in ci]


def test_ci_checks_the_code_with_ruff():
    """The ruff configuration is enforced: CI runs it after the tests, with the test extra's ruff."""
    ci = [ln.strip() for ln in (REPO / ".ci" / "run").read_text().splitlines()]
    assert ".venv/bin/ruff check ." in ci
    pyproject = (REPO / "pyproject.toml").read_text()
    assert "[tool.ruff]" in pyproject and '"ruff' in pyproject
