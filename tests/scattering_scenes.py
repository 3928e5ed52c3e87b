"""The scattering tests' small scenes, by dotted key: shared by the generic tests
(``tests/renderers/test_scattering.py``) and each GL renderer's own (``test_scattering_NAME.py``).
"""

from __future__ import annotations

SMALL = {"volume.demo": "shepp-logan", "volume.size": 12, "image.width": 14, "image.height": 12}


LIT = {**SMALL, "renderer.ert_threshold": 1.0,
       "renderer.scattering": {"enabled": True, "albedo": 0.9, "lights": [{"direction": [1.0, 0.3, -0.2],
                                                                          "intensity": 3.0}]},
       "transfer_function.points": [[0.0, 1.0, 0.8, 0.6, 0.0], [0.3, 1.0, 0.8, 0.6, 0.6],
                                    [1.0, 0.6, 0.8, 1.0, 0.9]]}


def with_column(overrides: dict, column) -> dict:
    """``overrides`` with its transfer function's points given a sixth column."""
    points = [[*row, a] for row, a in zip(overrides["transfer_function.points"], column)]
    return {**overrides, "transfer_function.points": points}


COLUMN_LIT = with_column(LIT, [0.1, 1.0, 0.4])


ALBEDO_BY_DEFAULT = {"renderer.scattering": {k: v for k, v in LIT["renderer.scattering"].items() if k != "albedo"}}
