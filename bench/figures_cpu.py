"""CPU time of the figures of ``servokit reproduce``, measured in one process (issue 24).

Runs the cases one after another in this process (``iter_cases(workers=1)``, as a
one-core machine would) with hooks on matplotlib: the CPU seconds of each figure from
its creation (``pyplot.figure``, which ``pyplot.subplots`` calls) to its closing
(``pyplot.close``, which :func:`servokit._figures.save_figure` calls), and within that
the layout pass (``Figure.tight_layout``) and the saves (``Figure.savefig``, or the
PNG path of :func:`servokit._figures.save_figure` that draws on the Agg canvas and
encodes its pixels: draw and encoding).  A figure's window also holds whatever its
plot function computes between creating and saving it (e.g. a spectrum evaluated for
the plot), so it is an upper bound of the drawing cost.  CPU is ``time.process_time``
(this process, all threads), so the figure share does not depend on the load of the
shared machine as wall time would.  Writes ``bench/out/figures_cpu.json``.

Run: ``MPLBACKEND=Agg python bench/figures_cpu.py [--case NAME ...] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from _timing import write_result


def _hook(
    totals: dict[str, float], counts: dict[str, int], per_figure: dict[str, tuple[float, float]]
) -> None:
    """Wrap pyplot.figure / pyplot.close / Figure.savefig / Figure.tight_layout and the
    file writes of :func:`~servokit._figures.save_figure` (to name each figure)."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    import servokit._figures as figures

    born: dict[int, float] = {}
    figure, close = plt.figure, plt.close
    savefig, tight = Figure.savefig, Figure.tight_layout

    saving: dict[int, float] = defaultdict(float)  # layout + savefig CPU of each open figure

    def timed(key: str, fn):
        def wrapper(fig, *args, **kwargs):
            t0 = time.process_time()
            try:
                return fn(fig, *args, **kwargs)
            finally:
                seconds = time.process_time() - t0
                totals[key] += seconds
                counts[key] += 1
                saving[id(fig)] += seconds

        return wrapper

    def figure_hook(*args, **kwargs):
        fig = figure(*args, **kwargs)
        born.setdefault(id(fig), time.process_time())
        return fig

    names: list[str] = []
    write = figures.write_atomic

    def write_hook(path, data):
        names.append(Path(path).name)
        return write(path, data)

    def close_hook(fig=None):
        start = born.pop(id(fig), None) if fig is not None else None
        close(fig)
        if start is not None:
            seconds = time.process_time() - start
            totals["figure_window"] += seconds
            counts["figure_window"] += 1
            name = names[-1] if names else f"figure {counts['figure_window']}"
            per_figure[name] = (seconds, saving.pop(id(fig), 0.0))
            names.clear()

    plt.figure, plt.close = figure_hook, close_hook
    figures.write_atomic = write_hook
    Figure.savefig = timed("savefig", savefig)
    Figure.tight_layout = timed("tight_layout", tight)
    if hasattr(figures, "_agg_png"):  # a PNG drawn and encoded without savefig
        figures._agg_png = timed("savefig", figures._agg_png)


def measure(cases: list[str], out: Path) -> dict:
    """CPU [s] of the whole serial run and of its figures; figure count and PNG bytes."""
    from servokit.cases.runner import iter_cases, select_cases

    totals: dict[str, float] = defaultdict(float)
    counts: dict[str, int] = defaultdict(int)
    per_figure: dict[str, tuple[float, float]] = {}
    _hook(totals, counts, per_figure)
    t0 = time.process_time()
    for _ in iter_cases(out, select_cases(cases or None, None), workers=1):
        pass
    total = time.process_time() - t0
    pngs = list(out.glob("*.png"))
    return {
        "cpu_s": total,
        "figure_window_cpu_s": totals["figure_window"],
        "tight_layout_cpu_s": totals["tight_layout"],
        "savefig_cpu_s": totals["savefig"],
        "n_figures": counts["figure_window"],
        "n_png": len(pngs),
        "png_bytes": sum(p.stat().st_size for p in pngs),
        # (creation to close, layout + savefig) of each figure, the costliest first
        "per_figure_cpu_s": dict(sorted(per_figure.items(), key=lambda kv: -kv[1][0])),
    }


def main() -> None:
    """Measure one serial run; print and write ``bench/out/figures_cpu.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", action="append", default=[], help="only these cases")
    parser.add_argument("--out", help="keep the figures here (default: a temporary directory)")
    args = parser.parse_args()
    import os

    with tempfile.TemporaryDirectory(prefix="servokit-figures-") as tmp:
        res = measure(args.case, Path(args.out) if args.out else Path(tmp) / "out")
    res["load_avg_1min"] = os.getloadavg()[0]
    print(
        f"serial run {res['cpu_s']:.1f} s CPU; figures {res['figure_window_cpu_s']:.1f} s "
        f"({res['n_figures']} figures: layout {res['tight_layout_cpu_s']:.1f} s, savefig "
        f"{res['savefig_cpu_s']:.1f} s); {res['n_png']} PNG, {res['png_bytes'] / 1e6:.1f} MB "
        f"(load {res['load_avg_1min']:.1f})"
    )
    write_result("figures_cpu", res)


if __name__ == "__main__":
    main()
