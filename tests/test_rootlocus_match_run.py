"""Batched branch matching of the root locus: the step-by-step rows bit for bit (issue 24)."""

from __future__ import annotations

import control
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.feedback.rootlocus import _match, _match_loop, _match_run, _roots_rows, root_locus


def _assert_same(a: list[np.ndarray], b: list[np.ndarray]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 7),
    steps=st.integers(0, 40),
    step=st.sampled_from([1e-9, 1e-3, 0.05, 0.5, 3.0]),
    ties=st.booleans(),
    shuffle=st.booleans(),
    scale=st.sampled_from([1e-12, 1.0, 1e9]),
)
def test_match_run_equals_the_loop(seed, n, steps, step, ties, shuffle, scale):
    """Random walks of roots (crossing, colliding, exactly tied, shuffled each step)."""
    rng = np.random.default_rng(seed)
    prev = rng.normal(size=n) + 1j * rng.normal(size=n)
    rows, cur = [], prev
    for _ in range(steps):
        cur = cur + step * (rng.normal(size=n) + 1j * rng.normal(size=n))
        r = np.round(cur) if ties else cur.copy()
        rows.append(r[rng.permutation(n)] if shuffle else r)
    prev, rows = prev * scale, [r * scale for r in rows]
    _assert_same(_match_run(prev, rows), _match_loop(prev, rows))


def test_match_run_odd_rows_take_the_loop():
    """A root gone to infinity (shorter row) and non-finite roots: the loop's rows."""
    prev = np.array([1 + 1j, -2 + 0j, 3 - 1j])
    rows = [prev + 0.1, np.array([1.1 + 1j, -2.1 + 0j]), np.array([1.2 + 1j, np.nan, 3 - 1j])]
    got, ref = _match_run(prev, rows), _match_loop(prev, rows)
    assert len(got) == 3
    for x, y in zip(got, ref, strict=True):
        np.testing.assert_array_equal(x, y)


def _root_locus_loop(g, gains):
    from servokit.feedback.rootlocus import RootLocus, _gains_polys

    k, polys, nd, w_ref = _gains_polys(g, gains)
    rows = [np.roots(nd)]
    for r in _roots_rows(polys[1:]):
        rows.append(_match(rows[-1], r))
    return RootLocus(gains=k, roots=np.array(rows) * w_ref)


@settings(max_examples=40, deadline=None)
@given(
    poles=st.lists(st.floats(-50.0, 5.0), min_size=2, max_size=6),
    damping=st.sampled_from([1e-6, 1e-3, 0.05, 0.7]),
    zero=st.floats(-60.0, -0.1),
)
def test_root_locus_equals_the_step_by_step_tracking(poles, damping, zero):
    """Real poles (coinciding ones give break-away points), a lightly damped pair."""
    den = np.poly(poles)
    den = np.polymul(den, [1.0, 2 * damping * 30.0, 900.0])
    g = control.tf([1.0, -zero], den)
    gains = np.geomspace(1e-3, 1e5, 400)
    got, ref = root_locus(g, gains), _root_locus_loop(g, gains)
    assert got.roots.tobytes() == ref.roots.tobytes()
