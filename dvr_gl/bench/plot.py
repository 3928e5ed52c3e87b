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


def peers_plot(rows: list[dict], path: Path):
    """PSNR against frame time (log), one panel per scene: dvr-gl's sample-distance sweeps as curves
    (post-classified, and pre-integrated where measured; each point labelled with its distance), each
    peer as one marked point."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    peers = list(dict.fromkeys(r["renderer"] for r in rows if r["renderer"] != "dvr-gl"))
    from matplotlib.ticker import LogFormatter, ScalarFormatter

    markers = dict(zip(peers, "s^vDP*X"))
    ncols = min(2, len(scenes))
    nrows = -(-len(scenes) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 4.2 * nrows), squeeze=False)
    for ax in axes.flat[len(scenes):]:
        ax.set_visible(False)
    for ax, scene in zip(axes.flat, scenes):
        mine = [r for r in rows if r["scene"] == scene and r["renderer"] == "dvr-gl"]
        for pre, style, label in ((False, "o-", "dvr-gl (sample distance)"),
                                  (True, "o--", "dvr-gl pre-integrated")):
            ours = sorted((r for r in mine if ("pre-integrated" in r["setting"]) == pre), key=lambda r: r["voxels"])
            if not ours:
                continue
            ax.plot([r["ms"] for r in ours], [r["psnr"] for r in ours], style, color="grey" if pre else "black",
                    markersize=4, label=label)
            for r in ours:
                ax.annotate(f"{r['voxels']:g}", (r["ms"], r["psnr"]), textcoords="offset points", xytext=(4, 4),
                            fontsize=7)
        for i, name in enumerate(peers):
            for r in (r for r in rows if r["scene"] == scene and r["renderer"] == name):
                ax.plot([r["ms"]], [r["psnr"]], markers[name], color=plt.cm.tab10(i % 10), markersize=7, label=name)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(1, 0.5)))
        ax.set_xlabel("frame time (ms, median)")
        ax.set_ylabel("PSNR dB vs converged reference")
        ax.set_title(scene)
        ax.grid(True, which="both", linewidth=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)
    plt.close(fig)
