"""Reduced loop factors: the per-system cache and the closed-form roots of low-order
sections (speed paths of issue 20) give what the uncached, general routes give."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.feedback import loop_response, stability_margins
from servokit.feedback.factor_response import _poly_roots, clear_factor_cache, make_factor

F = np.geomspace(1.0, 1e4, 200)


def test_a_repeated_system_is_reduced_once():
    sys = control.tf([1.0, 2.0], [1.0, 3.0, 2.0])
    assert make_factor(sys) is make_factor(sys)
    clear_factor_cache()
    fresh = make_factor(sys)
    assert fresh is not make_factor(control.tf([1.0, 2.0], [1.0, 3.0, 2.0]))  # new object


@pytest.mark.parametrize("kind", ["tf", "ss"])
def test_a_system_changed_in_place_is_reduced_again(kind):
    sys = control.tf([1.0, 2.0], [1.0, 3.0, 2.0])
    if kind == "ss":
        sys = control.ss(sys)
    before = loop_response(sys)[0](F)  # through the merged partial fractions
    if kind == "tf":
        sys.num[0][0][1] = 7.0
    else:
        sys.A[0, 0] = -5.0
    after = loop_response(sys)[0](F)
    assert after == pytest.approx(np.asarray(sys(2j * np.pi * F)).ravel(), rel=1e-10)
    assert not np.allclose(before, after)


def test_cached_margins_equal_cold_margins():
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark, ieej_example_controller

    loop = [hdd_benchmark().discretize(HDD_BENCHMARK_TS), *ieej_example_controller()]
    clear_factor_cache()
    cold = stability_margins(loop)
    warm = stability_margins(loop)
    assert warm == cold


def _residual(p: np.ndarray, roots: np.ndarray) -> float:
    """Backward error of the roots: ``|p(r)| / sum |p_k| |r|^k`` (rounding level if exact)."""
    worst = 0.0
    for r in roots:
        scale = float(np.sum(np.abs(p) * np.abs(r) ** np.arange(p.size - 1, -1, -1)))
        worst = max(worst, abs(np.polyval(p, r)) / scale if scale else 0.0)
    return worst


# coefficients 0 or of magnitude 1e-100..1e6 (a subnormal quotient underflows to 0)
_COEF = st.one_of(st.just(0.0), st.floats(1e-100, 1e6), st.floats(-1e6, -1e-100))


@settings(max_examples=300, deadline=None)
@given(
    st.lists(_COEF, min_size=1, max_size=2),
    st.floats(1e-6, 1e6),
    st.integers(0, 2),
)
def test_closed_form_roots_are_backward_stable(rest, lead, zeros_at_origin):
    # first and second-order sections (the closed forms), trailing zeros split off first
    p = np.array([lead, *rest, *([0.0] * zeros_at_origin)])
    ours = _poly_roots(p)
    assert ours.size == p.size - 1
    assert _residual(p, ours) < 1e-13
    assert np.sum(ours == 0) >= zeros_at_origin


@settings(max_examples=200, deadline=None)
@given(st.floats(0.5, 1.0), st.floats(1e-7, np.pi), st.floats(1e-3, 1e3))
def test_closed_form_roots_of_lightly_damped_sections(radius, angle, scale):
    # a discrete section's poles r e^{+-j theta}, down to the near-double roots near z = 1
    p = scale * np.array([1.0, -2 * radius * np.cos(angle), radius * radius])
    ours, ref = _poly_roots(p), np.roots(p).astype(complex)
    ours, ref = ours[np.argsort(ours.imag)], ref[np.argsort(ref.imag)]  # conjugate pairs
    assert _residual(p, ours) < 1e-14
    assert ours == pytest.approx(ref, abs=1e-7)  # both carry the sqrt(eps) of a double root
