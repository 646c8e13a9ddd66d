"""Margins to 1e-9 relative where the partial fractions cancel: clusters of nearly repeated
poles, lightly damped modes, rigid bodies, unstable loops, huge and tiny scales.

The references are independent of the margins core: crossings as roots of polynomials in
ω² solved by mpmath at 50 digits (an all-pole loop ``K / den(s)``: ``Im den(jω) = 0`` and
``|den(jω)|² = K²``, the generalised Routh-Hurwitz condition), or mpmath's secant root of
the loop evaluated at 40 digits from the system's own coefficients or matrices.
"""

from __future__ import annotations

import control
import mpmath
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from servokit.feedback import stability_margins
from servokit.feedback.accurate_response import accurate_evaluator
from servokit.feedback.factor_response import (
    _partial_fractions,
    _poly_roots,
    _tf_partial_fractions,
    loop_evaluator,
)
from servokit.feedback.margins import loop_factors

REL = 1e-9  # the accuracy asked of every crossing and margin
_SETTINGS = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow]}


def _mp_poly(c: np.ndarray, x: mpmath.mpc) -> mpmath.mpc:
    return mpmath.polyval([mpmath.mpf(float(v)) for v in c], x)


def _mp_loop(systems: list, f: mpmath.mpf) -> mpmath.mpc:
    """The loop at ``f`` [Hz] in mpmath from each system's own (double) data."""
    out = mpmath.mpc(1)
    for sys in systems:
        dt = sys.dt if sys.dt not in (None, 0, False, True) else None
        x = mpmath.exp(2j * mpmath.pi * f * dt) if dt else 2j * mpmath.pi * f
        if isinstance(sys, control.TransferFunction):
            out *= _mp_poly(sys.num[0][0], x) / _mp_poly(sys.den[0][0], x)
        else:
            a, b, c = (mpmath.matrix(np.asarray(m, float).tolist()) for m in (sys.A, sys.B, sys.C))
            y = mpmath.lu_solve(x * mpmath.eye(a.rows) - a, b)
            out *= (c * y)[0] + float(np.asarray(sys.D).ravel()[0])
    return out


def _mp_root(systems: list, f0: float, kind: str) -> float:
    """The true crossing nearest ``f0`` (secant at 40 digits on ``log|L|`` or ``Im L/|L|``)."""
    with mpmath.workdps(40):

        def h(f: mpmath.mpf) -> mpmath.mpf:
            v = _mp_loop(systems, f)
            return mpmath.log(abs(v)) if kind == "gain" else v.imag / abs(v)

        return float(mpmath.findroot(h, (mpmath.mpf(f0), mpmath.mpf(f0) * (1 + 1e-7))))


def _all_pole_reference(den: np.ndarray, k: float) -> tuple[list[float], list[float], list[float]]:
    """Phase crossovers [Hz], their gain margins (linear) and gain crossovers [Hz] of
    ``k / den(s)`` from polynomial roots in ω² at 50 digits."""
    with mpmath.workdps(50):
        n = den.size - 1
        c = [mpmath.mpf(float(v)) for v in den]  # den(s) = Σ c[i] s^(n-i)
        re = [mpmath.mpf(0)] * (n + 1)  # Re den(jω) and Im den(jω)/ω as polynomials in ω
        im = [mpmath.mpf(0)] * (n + 1)
        for i, ci in enumerate(c):
            p = n - i  # (jω)^p = j^p ω^p
            (re if p % 2 == 0 else im)[p] += ci * (1 if p % 4 in (0, 1) else -1)
        # Im den(jω) = ω q(ω²), q from the odd coefficients
        q = [im[p] for p in range(n if n % 2 else n - 1, 0, -2)]
        # a phase crossover needs L = k/den real and negative: Re den(jω) < 0
        w180 = [w for w in _positive_roots_in_w2(q) if mpmath.re(mpmath.polyval(c, 1j * w)) < 0]
        gms = [abs(mpmath.polyval(c, 1j * w)) / k for w in w180]
        # |den(jω)|² - k² as a polynomial in ω² (even by construction)
        mag = [mpmath.mpf(0)] * (2 * n + 1)
        for a in range(n + 1):
            for b in range(n + 1):
                mag[a + b] += re[a] * re[b] + im[a] * im[b]
        mag[0] -= k * k
        wc = _positive_roots_in_w2([mag[p] for p in range(2 * n, -1, -2)])
        hz = [float(w / (2 * mpmath.pi)) for w in w180]
        return hz, [float(g) for g in gms], [float(w / (2 * mpmath.pi)) for w in wc]


def _positive_roots_in_w2(coeffs: list) -> list:
    """Positive ω with ``Σ coeffs[i] (ω²)^(m-i) = 0`` (real positive roots in ω²)."""
    while coeffs and coeffs[0] == 0:
        coeffs = coeffs[1:]
    if len(coeffs) < 2:
        return []
    roots = mpmath.polyroots(coeffs, maxsteps=400, extraprec=400)
    scale = max(abs(r) for r in roots)
    real = [mpmath.re(r) for r in roots if abs(mpmath.im(r)) <= 1e-30 * scale]
    return sorted(mpmath.sqrt(r) for r in real if r > 0)


def _sorted_close(ours, ref, rel=REL) -> None:
    assert len(ours) == len(ref), (ours, ref)
    assert np.array(sorted(ours)) == pytest.approx(sorted(ref), rel=rel)


@settings(max_examples=25, **_SETTINGS)
@given(
    p0=st.floats(-3.0, 5.0),  # log10 of the cluster's pole [rad/s]
    gaps=st.lists(st.floats(-6.0, -3.0), min_size=1, max_size=3),  # log10 relative spacing
    others=st.lists(st.floats(-1.0, 1.0), max_size=2),  # log10 of other poles / p0
    k=st.floats(0.2, 5.0),  # loop gain / the first gain crossover's
    form=st.sampled_from(["tf", "ss"]),
)
@example(
    p0=np.log10(12.0),
    gaps=[np.log10(0.5 / 12), np.log10(0.046875 / 12.5)],
    others=[],
    k=1.0,
    form="tf",
)  # the nearly triple pole that gave 1.5e-6 (the root-locus test)
def test_clustered_poles_all_crossings_to_1e_9(p0, gaps, others, k, form):
    base = 10.0**p0
    poles = [base]
    for g in gaps:
        poles.append(poles[-1] * (1 + 10.0**g))
    poles += [base * 10.0**o for o in others]
    den = np.poly(-np.array(poles))
    k0 = k * abs(np.polyval(den, 1j * 0.5 * base))  # |L| = k at half the cluster frequency
    g = control.tf([k0], den)
    m = stability_margins(g if form == "tf" else control.ss(g))
    w180, gms, wc = _all_pole_reference(den, k0)
    _sorted_close(m.phase_crossovers_hz, w180)
    _sorted_close(10 ** (np.asarray(m.gain_margins_db) / 20), gms)
    _sorted_close(m.gain_crossovers_hz, wc)


def _lightly_damped_loop(zeta: float, scale: float, rigid: bool, gain: float, form: str):
    """A rigid body (or a low real pole) with a lead, a mode of damping ``zeta`` at 8 fc,
    and an unstable open-loop pole when not rigid; frequencies times ``scale``."""
    wc = 2 * np.pi * 100.0 * scale
    wm = 8 * wc
    plant = control.tf([wm**2], [1, 2 * zeta * wm, wm**2])
    plant *= control.tf([1], [1, 0, 0]) if rigid else control.tf([1], [1, -0.1 * wc])
    lead = control.tf([3 / wc, 1], [1 / (3 * wc), 1])
    open_loop = plant * lead
    k = gain / abs(complex(open_loop(1j * wc)))
    ctrl = k * lead
    if form == "ss":
        return [control.ss(plant), control.ss(ctrl)]
    return [plant, ctrl]


@settings(max_examples=20, **_SETTINGS)
@given(
    zeta=st.floats(-6.0, -1.0),
    scale=st.floats(-3.0, 3.0),
    rigid=st.booleans(),
    gain=st.floats(0.3, 3.0),
    form=st.sampled_from(["tf", "ss"]),
)
def test_lightly_damped_rigid_unstable_loops_against_mpmath(zeta, scale, rigid, gain, form):
    systems = _lightly_damped_loop(10.0**zeta, 10.0**scale, rigid, gain, form)
    m = stability_margins(systems)
    assert m.gain_crossovers_hz and m.phase_crossovers_hz
    for f in m.gain_crossovers_hz:
        assert f == pytest.approx(_mp_root(systems, f, "gain"), rel=REL)
    for f in m.phase_crossovers_hz:
        assert f == pytest.approx(_mp_root(systems, f, "phase"), rel=REL)
    with mpmath.workdps(40):
        ref = [complex(_mp_loop(systems, mpmath.mpf(f))) for f in m.gain_crossovers_hz]
        l180 = [complex(_mp_loop(systems, mpmath.mpf(f))) for f in m.phase_crossovers_hz]
    pm = 180 + np.degrees(np.angle(ref))
    pm = 180.0 - np.mod(180.0 - pm, 360.0)
    assert np.array(m.phase_margins_deg) == pytest.approx(pm, abs=REL * 180)
    assert 10 ** (-np.array(m.gain_margins_db) / 20) == pytest.approx(np.abs(l180), rel=REL)
    dms = np.radians(np.mod(pm, 360.0)) / (2 * np.pi * np.array(m.gain_crossovers_hz))
    assert np.array(m.delay_margins_s) == pytest.approx(dms, rel=REL)


def test_discrete_cluster_against_mpmath():
    # the nearly triple pole sampled (ZOH) at 20x its crossover: clustered poles in z
    g = control.tf([1.0], np.poly([-12.0, -12.5, -12.546875]))
    gd = control.sample_system(g * 2500.0, 1 / (20 * 3.4), method="zoh")
    m = stability_margins(gd)
    assert m.phase_crossovers_hz
    for f in m.phase_crossovers_hz:
        assert f == pytest.approx(_mp_root([gd], f, "phase"), rel=REL)
    for f in m.gain_crossovers_hz:
        assert f == pytest.approx(_mp_root([gd], f, "gain"), rel=REL)


def test_cancelling_partial_fractions_are_not_used():
    # the cause of the root-locus test's 1.5e-6: the partial fractions of a nearly triple
    # pole lose digits at the crossover (measured here); the factor now keeps Horner
    g = control.tf([1.0], np.poly([-12.0, -12.5, -12.546875]))
    num, den = g.num[0][0], g.den[0][0]
    f = np.array([3.403826930223387])
    with mpmath.workdps(40):
        ref = complex(_mp_loop([g], mpmath.mpf(float(f[0]))))
    pf = _tf_partial_fractions(num, den, _poly_roots(den))
    fractions = _partial_fractions(*pf, lambda x: 2j * np.pi * x)(f)[0]
    assert abs(fractions - ref) > 1e-7 * abs(ref)
    factors, dt = loop_factors(g)
    assert factors[0].pf is None
    assert abs(loop_evaluator(factors, 0.0, dt)(f)[0] - ref) <= 1e-14 * abs(ref)


def test_accurate_evaluator_at_the_crossings_of_the_dual_stage_loop():
    # Table 5.2's loop: partial fractions cancel (kappa ~ 100-400) at the highest phase
    # crossover, where the LU solve / Horner forms take over
    from servokit.models import vcm_controller_table_5_2, vcm_dual_stage

    ctrl = vcm_controller_table_5_2()
    systems = [vcm_dual_stage().discretize(ctrl.dt), ctrl]
    m = stability_margins(systems)
    factors, dt = loop_factors(systems)
    fine = accurate_evaluator(factors, 0.0, dt)
    f = np.array([*m.gain_crossovers_hz, *m.phase_crossovers_hz])
    with mpmath.workdps(40):
        ref = np.array([complex(_mp_loop(systems, mpmath.mpf(x))) for x in f])
    assert np.abs(fine(f) - ref) == pytest.approx(0.0, abs=1e-13 * np.abs(ref).max())
    l180 = ref[len(m.gain_crossovers_hz) :]
    assert np.abs(np.angle(-l180)) == pytest.approx(0.0, abs=1e-12)
