"""The documentation stays true: the scene-format reference is what the schema generates, the README
is the front door (under 400 lines) and its links resolve."""

import re

from conftest import REPO
from dvr_gl.scene.reference import reference_text


def test_scene_format_reference_is_current():
    """docs/scene-files.md is generated from the schema and the renderers' declared settings; after
    changing a key: python -m dvr_gl.scene.reference docs/scene-files.md"""
    page = (REPO / "docs" / "scene-files.md").read_text(encoding="utf-8")
    assert page == reference_text(), ("docs/scene-files.md is stale: "
                                      "python -m dvr_gl.scene.reference docs/scene-files.md")


def test_reference_documents_every_key():
    text = reference_text()
    from dvr_gl.renderers import registry

    for setting in registry.all_settings():
        assert f"`renderer.{setting.name}`" in text
    for key in ("volume.path", "transfer_function.points", "camera.azimuth", "image.background",
                "renderer.shading.shininess"):
        assert f"`{key}`" in text


def test_readme_is_the_front_door():
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) < 400


def test_relative_links_resolve():
    """Every relative link in README.md, docs/ and the pages in the package (each renderer's README.md in its
    folder, benchmarks/README.md) names a file that exists."""
    pages = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md")), *sorted((REPO / "dvr_gl").rglob("*.md")),
             *sorted((REPO / "benchmarks").glob("*.md"))]
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            path = (page.parent / target.split("#")[0]).resolve()
            if not path.exists():
                broken.append(f"{page.relative_to(REPO)} -> {target}")
    assert not broken, broken
