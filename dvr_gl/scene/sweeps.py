"""Trade-off sweep families: one accuracy setting varied, the others at the scene's values.

A renderer plugin lists the families that vary something it reads (``sweeps``);
``dvr bench tradeoff`` renders every registered renderer through its families and
measures error against time (:mod:`dvr_gl.bench.tradeoff`).
"""

from __future__ import annotations

from dataclasses import dataclass

DISTANCES = (4.0, 2.0, 1.0, 0.5, 0.25, 0.125)   # sample distances, voxels


@dataclass(frozen=True)
class Family:
    """One curve: the renderer setting ``key`` takes ``values`` with ``fixed`` set (dotted scene keys, a
    table's own keys too: ``renderer.scattering.method``), for fields of ``data_kinds`` (None: any the
    renderer renders) and scenes where the renderer setting ``needs`` is true (None: any)."""

    label: str
    key: str
    values: tuple
    fixed: tuple = ()   # ((dotted key, value), ...)
    data_kinds: tuple | None = None
    needs: str | None = None

    def applies_to(self, kind: str | None) -> bool:
        return kind is None or self.data_kinds is None or kind in self.data_kinds

    def applies_to_scene(self, scene) -> bool:
        """Whether the scene uses what the family varies (``needs``)."""
        if self.needs is None:
            return True
        value = scene.renderer
        for part in self.needs.removeprefix("renderer.").split("."):
            value = getattr(value, part)
        return bool(value)


POST = Family("post, linear", "renderer.sample_distance_voxels", DISTANCES)
PRE_CLASSIFIED = Family("pre-classified", "renderer.sample_distance_voxels", DISTANCES,
                        (("renderer.classification", "pre"),))
PREINTEGRATED = Family("pre-integrated", "renderer.sample_distance_voxels", DISTANCES,
                       (("renderer.classification", "preintegrated"),))
PREINTEGRATED_FAST = Family("pre-integrated fast", "renderer.sample_distance_voxels", DISTANCES,
                            (("renderer.classification", "preintegrated"), ("renderer.preintegration", "fast")))
NEAREST = Family("nearest", "renderer.sample_distance_voxels", DISTANCES, (("renderer.filter", "nearest"),))
CUBIC_BSPLINE = Family("cubic B-spline", "renderer.sample_distance_voxels", DISTANCES[2:],
                       (("renderer.filter", "cubic_bspline"),))
LUT_SIZE = Family("LUT size", "renderer.lut_size", (64, 256, 1024, 4096, 16384))
PREINTEGRATION_TABLE = Family("pre-integration table", "renderer.preintegration_size", (32, 64, 128, 256, 512),
                              (("renderer.classification", "preintegrated"), ("renderer.sample_distance_voxels", 1.0)))
EARLY_TERMINATION = Family("early termination", "renderer.ert_threshold", (0.8, 0.9, 0.95, 0.99, 1.0))
BRICKED = Family("bricked 4 MB", "renderer.sample_distance_voxels", DISTANCES[1:5],
                 (("renderer.texture_budget_mb", 4.0),))
CLASSIFICATION = Family("classification", "renderer.classification", ("post", "pre", "preintegrated"))
#: The light volume's resolution, where the scene scatters (the shadow rays' family is the sample distance's).
LIGHT_VOLUME = Family("light volume", "renderer.scattering.light_volume_size", (16, 32, 64, 128, 256),
                      (("renderer.scattering.method", "light_volume"),), needs="renderer.scattering.enabled")
