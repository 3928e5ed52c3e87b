"""Benchmarks behind ``dvr bench``: each returns rows for :func:`format_table`.

Progress (:mod:`dvr_gl.progress`): a bench runs inside :func:`counting`, whose bar counts the frames
measured (:func:`tick`); a converged reference, the longest single piece of work, gets its own bar
(:func:`converged`).
"""

from __future__ import annotations

import contextlib
import contextvars

from .. import progress

_ticks: contextvars.ContextVar = contextvars.ContextVar("dvr_gl_bench_ticks", default=None)


@contextlib.contextmanager
def counting(label: str):
    """A bar over a whole bench (total unknown): each :func:`tick` within the block moves it."""
    with progress.task(label, unit="frame") as step:
        done = 0

        def count():
            nonlocal done
            done += 1
            step(done)

        token = _ticks.set(count)
        try:
            yield count
        finally:
            _ticks.reset(token)


def tick():
    """A frame was measured (nothing happens outside :func:`counting`)."""
    count = _ticks.get()
    if count is not None:
        count()


def converged(reference, float64: bool = False):
    """``reference.render()`` (``render_float64()`` if ``float64``) of a
    :class:`~dvr_gl.reference.converged.ConvergedReference`, with a bar over its rays."""
    with progress.task("converged reference", unit="ray") as step:
        reference.progress = step
        image = reference.render_float64() if float64 else reference.render()
    tick()
    return image


def volume_keys(path: str | None, size: int) -> tuple[dict, str]:
    """A bench's volume as scene keys, and in words: the file ``path`` (``--volume FILE``), else the
    Shepp-Logan demo on ``size``^3 nodes (``--volume-size N``)."""
    if path:
        return {"volume.path": str(path)}, str(path)
    return {"volume.demo": "shepp-logan", "volume.size": size}, f"Shepp-Logan {size}^3"


def format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Rows as a text table; ``columns`` are (key, heading, format spec)."""
    cells = [[h for _, h, _ in columns]] + [[format(r[k], f) if r.get(k) is not None else "-"
                                              for k, _, f in columns] for r in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(columns))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
             for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_markdown(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Rows as a Markdown table (what ``--markdown`` writes for the docs)."""
    def cell(r, k, f):
        return (format(r[k], f) if r.get(k) is not None else "-").strip().replace("|", "\\|")
    lines = ["| " + " | ".join(h.replace("|", "\\|") for _, h, _ in columns) + " |",
             "|" + "|".join("---" if i == 0 else "---:" for i in range(len(columns))) + "|"]
    lines += ["| " + " | ".join(cell(r, k, f) for k, _, f in columns) + " |" for r in rows]
    return "\n".join(lines)


class Report:
    """What a bench prints, also collected as Markdown for ``--markdown FILE`` (the docs' measured
    tables are written this way, never pasted)."""

    def __init__(self):
        self.parts: list[str] = []

    def text(self, line: str = ""):
        print(line)
        self.parts.append(line)

    def table(self, rows: list[dict], columns, notes=()):
        """The rows as a table, then each of ``notes`` (what was left out, and why) as a line."""
        print(format_table(rows, columns))
        self.parts += ["", format_markdown(rows, columns), ""]
        for note in notes:
            self.text(note)

    def markdown(self, command: str) -> str:
        import datetime
        import platform

        header = (f"<!-- written by `{command}` on {datetime.date.today().isoformat()}, {platform.machine()} "
                  f"with {_gl_renderer()}; run it again to update -->")
        return header + "\n\n" + "\n".join(self.parts).strip() + "\n"


def _gl_renderer() -> str:
    try:
        from ..gl.context import create_context, release_context

        ctx = create_context()
        try:
            return ctx.info["GL_RENDERER"]
        finally:
            release_context(ctx)
    except Exception:  # the machine is described for the record only
        return "an unknown GL renderer"


def median_seconds(renderer, scene, repeat: int, stat: str = "seconds", warm_up: bool = True) -> float:
    """Median over ``repeat`` renders of ``renderer.stats[stat]`` (after one untimed render)."""
    import statistics

    if warm_up:
        renderer.render(scene)
    times = []
    for _ in range(repeat):
        renderer.render(scene)
        times.append(renderer.stats[stat])
        tick()
    return statistics.median(times)
