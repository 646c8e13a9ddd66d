"""CPU time of the reproduce cases' computation, figures not saved (issue 24, item 3).

Runs each case serially in this process (``servokit.cases.runner.iter_cases``, one BLAS
thread) with ``save_figure`` replaced by a stub that only closes the figure, so the
number is the computation plus building the plots, without laying them out and drawing
them (the figures' own CPU is measured by ``figures_cpu.py``).  The case modules are
imported first and not counted.  Compare two trees by running this with each tree's
``src`` on ``PYTHONPATH``, alternately.  Writes ``bench/out/compute_cpu.json``.

Run: ``MPLBACKEND=Agg PYTHONPATH=$PWD/src python bench/compute_cpu.py [CASE ...]``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from _timing import write_result


def _stub_figures() -> None:
    """Make every ``save_figure`` (the module's and the names imported from it) a close."""
    import matplotlib.pyplot as plt

    import servokit._figures as figures
    from servokit.cases.registry import registry

    def stub(fig, path, *args, **kwargs):
        plt.close(fig)
        return Path(path)

    registry()  # imports every case module (and what they import) before patching
    original = figures.save_figure
    for module in list(sys.modules.values()):
        if getattr(module, "save_figure", None) is original:
            module.save_figure = stub


def main() -> None:
    """CPU seconds per case, printed and written to ``bench/out/compute_cpu.json``."""
    from servokit.cases.runner import iter_cases, select_cases

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", help="case names (default: all)")
    args = parser.parse_args()
    _stub_figures()
    result: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="servokit-compute-") as tmp:
        for name in select_cases(args.cases or None, None):
            start = time.process_time()
            for _ in iter_cases(Path(tmp), [name], workers=1):
                pass
            result[name] = time.process_time() - start
            print(f"{result[name]:8.3f}  {name}")
    print(f"{sum(result.values()):8.3f}  total CPU [s] of the computation (figures not saved)")
    write_result("compute_cpu", result)


if __name__ == "__main__":
    main()
