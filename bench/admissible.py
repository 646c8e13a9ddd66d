"""Maximal output admissible sets of the switching-admissible case (17-state HDD loop,
|u| <= 1 A, the IVC and zero-reset 2-D slices): certificates vs the LP-only path
(issue 24: 1749 ``linprog`` calls made 10 % of ``servokit reproduce``).

The LP-only reference is the code before the change, kept in
``tests/test_switching_admissible_lp.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from servokit.switching import ivc_jmin, max_output_admissible_set  # noqa: E402


def _counted(fn):
    """Run ``fn()`` counting the HiGHS calls; (result, calls, CPU seconds)."""
    import scipy.optimize

    calls = [0]
    real = scipy.optimize.linprog

    def counting(*a, **k):
        calls[0] += 1
        return real(*a, **k)

    # admissible_lp imports linprog from scipy.optimize on use (start-up): patch it there
    scipy.optimize.linprog = counting
    try:
        c0 = time.process_time()
        out = fn()
        return out, calls[0], time.process_time() - c0
    finally:
        scipy.optimize.linprog = real


def admissible() -> dict:
    """CPU seconds and LP counts of O_inf and its two slices, new path and LP-only."""
    from servokit.cases.switching_admissible import _slice, admissible_loop
    from tests.test_switching_admissible_lp import _ref_prune, _ref_set

    loop = admissible_loop()
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    maps = [loop.stack(G) @ _slice(loop) for G in (K, np.zeros_like(K))]

    def new():
        full = max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)
        return full, [full.restrict(E) for E in maps]

    def old():
        H, h, t_star = _ref_set(loop.A, loop.Cu, -1.0, 1.0)
        return (H, h, t_star), [_ref_prune(H @ E, h) for E in maps]

    (full, slices), n_new, t_new = _counted(new)
    ((H, h, t_star), ref_slices), n_old, t_old = _counted(old)
    same = full.t_star == t_star and all(
        s.H.shape == Hr.shape and np.allclose(s.H, Hr, rtol=0, atol=1e-9)
        and np.allclose(s.h, hr, rtol=1e-9, atol=1e-12)
        for s, (Hr, hr) in zip([full, *slices], [(H, h), *ref_slices], strict=True)
    )  # fmt: skip
    return {
        "states": int(loop.A.shape[0]),
        "t_star": int(full.t_star),
        "rows": int(full.H.shape[0]),
        "certificates_cpu_s": t_new,
        "lp_only_cpu_s": t_old,
        "speedup": t_old / t_new,
        "certificates_linprog_calls": n_new,
        "lp_only_linprog_calls": n_old,
        "same_sets": bool(same),
    }


if __name__ == "__main__":
    for k, v in admissible().items():
        print(f"  {k:30s} {v:.4g}" if isinstance(v, float) else f"  {k:30s} {v}")
