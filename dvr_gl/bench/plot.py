"""Plots of benchmark results (optional: needs matplotlib, the ``plot`` extra)."""

from __future__ import annotations

from pathlib import Path


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def tradeoff_plot(rows: list[dict], path: Path, error: str = "rms"):
    """Error against frame time, log-log, one panel per scene: one curve per renderer and setting
    family (colour: renderer; marker: family), the Pareto front as a black staircase."""
    import matplotlib

    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    renderers = list(dict.fromkeys(r["renderer"] for r in rows))
    families = list(dict.fromkeys(r["family"] for r in rows))
    colours = {name: plt.cm.tab10(i % 10) for i, name in enumerate(renderers)}
    markers = {name: "os^vD<>pPX*h"[i % 12] for i, name in enumerate(families)}
    fig, axes = plt.subplots(1, len(scenes), figsize=(6.5 * len(scenes), 5.5), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        here = [r for r in rows if r["scene"] == scene and r[error] > 0]
        for name in renderers:
            for family in families:
                curve = [r for r in here if r["renderer"] == name and r["family"] == family]
                if curve:
                    ax.plot([r["ms"] for r in curve], [r[error] for r in curve], marker=markers[family],
                            color=colours[name], linewidth=0.8, markersize=4, alpha=0.8,
                            label=f"{name}: {family}")
        front = sorted((r for r in here if r.get("pareto")), key=lambda r: r["ms"])
        if front:
            ax.step([r["ms"] for r in front], [r[error] for r in front], where="post", color="black",
                    linewidth=1.6, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frame time (ms, median)")
        ax.set_ylabel(f"{error.upper()} error vs converged reference")
        ax.set_title(scene)
        ax.grid(True, which="both", linewidth=0.3)
    axes[0][-1].legend(fontsize=6, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)
    plt.close(fig)
