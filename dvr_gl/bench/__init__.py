"""Benchmarks behind ``dvr bench``: each returns rows for :func:`format_table`."""

from __future__ import annotations


def format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Rows as a text table; ``columns`` are (key, heading, format spec)."""
    cells = [[h for _, h, _ in columns]] + [[format(r[k], f) if r.get(k) is not None else "-"
                                              for k, _, f in columns] for r in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(columns))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
             for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def median_seconds(renderer, scene, repeat: int, stat: str = "seconds", warm_up: bool = True) -> float:
    """Median over ``repeat`` renders of ``renderer.stats[stat]`` (after one untimed render)."""
    import statistics

    if warm_up:
        renderer.render(scene)
    times = []
    for _ in range(repeat):
        renderer.render(scene)
        times.append(renderer.stats[stat])
    return statistics.median(times)
