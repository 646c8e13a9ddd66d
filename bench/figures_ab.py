"""Two ways of saving the report's figures compared in one process (issue 24).

``--capture DIR`` runs the cases of ``servokit reproduce`` (in this process) and
pickles every figure as :func:`servokit._figures.save_figure` receives it, before it
is laid out.  ``--against FILE`` then saves each pickled figure with the
``save_figure`` of FILE (e.g. ``git show REV:src/servokit/_figures.py > FILE``) and
with the one of this tree, figure by figure, the order alternating, for ``--rounds``
rounds: the load of a shared machine falls on both alike.  Reports the CPU seconds
(``time.process_time``) of each round and whether the two PNG files of every figure
decode to the same pixels, in every round (the first runs with this tree's
process-wide text caches of :mod:`servokit._agg_text` cold, the later ones warm).
Writes ``bench/out/figures_ab.json``.

Run: ``MPLBACKEND=Agg python bench/figures_ab.py --capture DIR`` then
``MPLBACKEND=Agg python bench/figures_ab.py --figures DIR --against FILE``.
"""

from __future__ import annotations

import argparse
import importlib.util
import pickle
import sys
import tempfile
import time
import weakref
from pathlib import Path

from _timing import write_result


def capture(out: Path) -> int:
    """Pickle every figure entering ``save_figure`` (its first call, ``set_dpi``)."""
    from matplotlib.figure import Figure

    import servokit._figures as figures
    from servokit.cases.runner import iter_cases, select_cases

    out.mkdir(parents=True, exist_ok=True)
    set_dpi, write = Figure.set_dpi, figures.write_atomic
    names: list[str] = []
    seen: weakref.WeakSet = weakref.WeakSet()  # ids of closed figures are reused
    count = [0]

    def set_dpi_hook(fig, dpi):
        if sys._getframe(1).f_code.co_name == "save_figure" and fig not in seen:
            seen.add(fig)
            count[0] += 1
            (out / f"{count[0]:03d}.pkl").write_bytes(pickle.dumps(fig))
        return set_dpi(fig, dpi)

    def write_hook(path, data):
        names.append(Path(path).name)
        return write(path, data)

    Figure.set_dpi, figures.write_atomic = set_dpi_hook, write_hook
    with tempfile.TemporaryDirectory() as tmp:
        for _ in iter_cases(Path(tmp), select_cases(None, None), workers=1):
            pass
    (out / "names.txt").write_text("\n".join(names))
    return count[0]


def compare(figures_dir: Path, baseline: Path, rounds: int) -> dict:
    """CPU [s] per round of the baseline's and this tree's saves; figures whose pixels differ."""
    import numpy as np
    from PIL import Image

    import servokit._figures as new

    spec = importlib.util.spec_from_file_location("baseline_figures", baseline)
    old = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(old)
    names = (figures_dir / "names.txt").read_text().split("\n")
    blobs = [p.read_bytes() for p in sorted(figures_dir.glob("*.pkl"))]
    cpu = {"baseline": [0.0] * rounds, "this_tree": [0.0] * rounds}
    differ: set[str] = set()
    with tempfile.TemporaryDirectory() as tmp:
        dirs = {k: Path(tmp) / k for k in cpu}
        for d in dirs.values():
            d.mkdir()
        for r in range(rounds):
            for i, blob in enumerate(blobs):
                order = ("baseline", "this_tree") if (i + r) % 2 == 0 else ("this_tree", "baseline")
                for which in order:
                    fig = pickle.loads(blob)
                    t0 = time.process_time()
                    (old if which == "baseline" else new).save_figure(fig, dirs[which] / names[i])
                    cpu[which][r] += time.process_time() - t0
                # every round: later rounds run with the process-wide text caches warm
                a, b = (np.asarray(Image.open(dirs[k] / names[i])) for k in dirs)
                if a.shape != b.shape or (a != b).any():
                    differ.add(f"{names[i]} (round {r + 1})")
    return {
        "n_figures": len(blobs),
        "baseline_cpu_s": cpu["baseline"],
        "this_tree_cpu_s": cpu["this_tree"],
        "pixels_differ": sorted(differ),
    }


def main() -> None:
    """Capture the figures, or compare two ``save_figure`` on captured figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--capture", help="pickle the report's figures into this directory")
    parser.add_argument("--figures", help="a directory written by --capture")
    parser.add_argument("--against", help="the baseline _figures.py")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if args.capture:
        print(f"{capture(Path(args.capture))} figures pickled in {args.capture}")
        return
    if not (args.figures and args.against):
        parser.error("give --capture DIR, or --figures DIR and --against FILE")
    res = compare(Path(args.figures), Path(args.against), args.rounds)
    base, this = res["baseline_cpu_s"], res["this_tree_cpu_s"]
    print(
        f"{res['n_figures']} figures; CPU per round: baseline "
        + " ".join(f"{x:.2f}" for x in base)
        + " s, this tree "
        + " ".join(f"{x:.2f}" for x in this)
        + f" s; pixels differ in {len(res['pixels_differ'])}"
    )
    write_result("figures_ab", res)


if __name__ == "__main__":
    main()
