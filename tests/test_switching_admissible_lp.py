"""Admissible sets with certificates (issue 24) against the LP-only path they replaced.

The reference below is the LP-per-question code of ``switching/admissible.py`` before
the certificates: one HiGHS LP per finite-determination candidate and per pruned row.
The new path must return the same ``t_star`` and the same rows (1e-9).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.switching import admissible as adm
from servokit.switching import admissible_lp, ivc_jmin, max_output_admissible_set
from tests.test_switching_ivc import random_loop


def _ref_prune(H, h):
    H, h = adm._normalise(H, h)
    _, first = np.unique(np.round(np.hstack([H, h[:, None]]), 12), axis=0, return_index=True)
    H, h = H[np.sort(first)], h[np.sort(first)]
    keep = np.ones(len(h), dtype=bool)
    for i in range(len(h)):
        others = keep.copy()
        others[i] = False
        lim = h[i] + 1e-9 * (1 + abs(h[i]))
        if others.any() and admissible_lp.lp_max(H[i], H[others], h[others]) <= lim:
            keep[i] = False
    return H[keep], h[keep]


def _ref_set(A, Cz, lo, hi, t_max=500):
    """O_inf by one LP per question (the path before issue 24)."""
    A, Cz = np.atleast_2d(A), np.atleast_2d(Cz)
    p = Cz.shape[0]
    lo, hi = np.broadcast_to(lo, (p,)).astype(float), np.broadcast_to(hi, (p,)).astype(float)
    H, h = adm._normalise(np.vstack([Cz, -Cz]), np.concatenate([hi, -lo]))
    M = Cz @ A
    for t in range(1, t_max + 1):
        cand, cb = adm._normalise(np.vstack([M, -M]), np.concatenate([hi, -lo]))
        if all(
            admissible_lp.lp_max(c, H, h) <= b + 1e-9 * (1 + abs(b))
            for c, b in zip(cand, cb, strict=True)
        ):
            return (*_ref_prune(H, h), t - 1)
        H, h = np.vstack([H, cand]), np.concatenate([h, cb])
        M = M @ A
    raise AssertionError("not determined")


def _same(new, H, h, t_star=None):
    if t_star is not None:
        assert new.t_star == t_star
    assert new.H.shape == H.shape
    np.testing.assert_allclose(new.H, H, rtol=0, atol=1e-9)
    np.testing.assert_allclose(new.h, h, rtol=1e-9, atol=1e-12)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 3), st.integers(1, 2), st.booleans())
def test_random_loops_same_as_lp_path(seed, n, m, symmetric):
    loop = random_loop(seed, n, m)
    lo = -1.0 if symmetric else -0.3
    new = max_output_admissible_set(loop.A, loop.Cu, lo, 1.0)
    _same(new, *_ref_set(loop.A, loop.Cu, lo, 1.0))
    # the IVC slice in plant coordinates (2-D or 3-D: vertex certificates) and a 2-D
    # slice with an offset (the origin outside: the Chebyshev centre as interior point)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    E = loop.stack(K)
    _same(new.restrict(E), *_ref_prune(new.H @ E, new.h))
    E2 = np.eye(n + m)[:, :2]
    off = 0.3 * new.ray_limit(np.ones(n + m)) * np.ones(n + m) / np.sqrt(n + m)
    _same(new.restrict(E2, off), *_ref_prune(new.H @ E2, new.h - new.H @ off))


def test_unbounded_cylinder_same_as_lp_path():
    A, Cz = np.diag([0.5, 0.9]), np.array([[1.0, 0.0]])
    _same(max_output_admissible_set(A, Cz, -1, 1), *_ref_set(A, Cz, -1, 1))


@pytest.mark.slow
def test_hdd_loop_same_as_lp_path():
    # the 17-state loop of the switching-admissible case (251 + 2 x 166 LPs before)
    from servokit.cases.switching_admissible import _slice, admissible_loop

    loop = admissible_loop()
    H, h, t_star = _ref_set(loop.A, loop.Cu, -1.0, 1.0)
    new = max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)
    _same(new, H, h, t_star)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    E = loop.stack(K) @ _slice(loop)
    _same(new.restrict(E), *_ref_prune(new.H @ E, new.h))


def test_certificates_skip_most_lps(monkeypatch):
    loop = random_loop(3, 3, 2)
    calls = []
    real = admissible_lp.lp_max
    monkeypatch.setattr(admissible_lp, "lp_max", lambda *a: calls.append(1) or real(*a))
    S = max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)
    n_questions = 2 * (S.t_star + 1) + len(S.h)  # at least this many LPs before
    assert len(calls) < n_questions / 2
