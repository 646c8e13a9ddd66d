"""servokit.feedback.ssa's numpy cores (``*_response``, ``amd_statespace``,
``amd_mode_damping``) against the python-control objects of the same module.

The CLI evaluates the bridges and the AMD loop with these cores (start-up, issue 23); every
number must be the python-control one.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.ssa import (
    amd_controller,
    amd_mode_damping,
    amd_response,
    amd_statespace,
    ddssa_bridge,
    ddssa_response,
    idssa_bridge,
    idssa_response,
    mode_damping,
)
from servokit.models import ModalPlant, Mode, pzt_active_suspension

caps = st.floats(1e-12, 1e-6)  # pF to uF
res = st.floats(1e2, 1e9)
freqs = st.floats(1e-2, 1e7)


def _close(got: np.ndarray, want: np.ndarray, scale: float) -> None:
    # python-control's path evaluates minreal'd polynomials: a few digits fewer at 10 MHz
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12 * scale)


@settings(max_examples=60, deadline=None)
@given(caps, caps, caps, caps, st.one_of(st.none(), st.tuples(res, res)), freqs)
def test_ddssa_response_equals_the_transfer_functions(cp, c1, c2, c3, resistors, f):
    r1, r3 = resistors or (None, None)
    bridge = ddssa_bridge(cp, c1, c2, c3, r1=r1, r3=r3)
    from_um, from_vm, balanced = ddssa_response(cp, c1, c2, c3, [f, 3 * f], r1=r1, r3=r3)
    s = 2j * np.pi * np.array([f, 3 * f])
    # from_um is a difference of two arms of size <= 1: absolute round-off of that size
    _close(from_um, np.asarray(bridge.from_um(s)).ravel(), 1.0)
    _close(from_vm, np.asarray(bridge.from_vm(s)).ravel(), 1.0)
    assert balanced == bridge.balanced


def _idssa_exact(c, cp, cpr, r, f) -> complex:
    """``vS/uM`` of (5.63)-(5.64) in 40 digits (mpmath)."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 40
    s, m = 2j * mp.pi * mp.mpf(f), [mp.mpf(x) for x in (*c, cp, cpr, *r)]

    def arm(ca, cb, cq, ra, rb):
        den = ca * cb * ra * rb * s * s + (cq + ca + cb) * ra * s + 1
        return 1 + (ca * cq * ra * rb * s * s + ca * rb * s) / den

    r1, r2, r3, r4, r5, r6, r7, r8 = m[6:]
    a2, a1 = r6 / (r5 + r6) * (r7 + r8) / r8, r7 / r8
    return complex(a2 * arm(m[2], m[3], m[5], r3, r4) - a1 * arm(m[0], m[1], m[4], r1, r2))


@settings(max_examples=60, deadline=None)
@given(st.tuples(caps, caps, caps, caps), caps, caps, st.tuples(*[res] * 8), freqs)
def test_idssa_response_is_the_printed_equations(c, cp, cpr, r, f):
    """Against a 40-digit evaluation: python-control's minreal'd difference of the arms
    is off by up to 1e-5 relative for such random components (it cancels nearly common
    poles and zeros), so it is compared only at the CLI's balanced bridge below."""
    from_um, from_vm, highpass = idssa_response(c, cp, cpr, r, f)
    exact = _idssa_exact(c, cp, cpr, r, f)
    a = r[5] / (r[4] + r[5]) * (r[6] + r[7]) / r[7] + r[6] / r[7]  # each arm is O(a)
    assert abs(complex(from_um) - exact) <= 1e-13 * max(abs(exact), a)
    bridge = idssa_bridge(c, cp, cpr, r)
    assert highpass == (bridge.fc_hz, bridge.damping, bridge.gain)
    want_vm = complex(bridge.from_vm(2j * np.pi * f))  # no minreal on this one
    assert abs(complex(from_vm) - want_vm) <= 1e-12 * max(abs(want_vm), a)


@pytest.mark.parametrize("k", [1.0, 2.0, 7.5])
def test_idssa_response_equals_python_control_on_a_balanced_bridge(k):
    args = ((1e-9,) * 4, 1e-9, 1e-9, (1e4,) * 4 + (1e3, k * 1e3, k * 1e3, 1e3))
    bridge = idssa_bridge(*args)
    f = bridge.fc_hz * np.geomspace(1e-3, 1e3, 13)
    from_um, from_vm, _ = idssa_response(*args, f)
    s = 2j * np.pi * f
    np.testing.assert_allclose(from_vm, np.asarray(bridge.from_vm(s)).ravel(), rtol=1e-12)
    assert np.all(np.abs(from_um) <= 1e-12 * (1 + k))  # balance (5.65): uM cancels
    assert np.all(np.abs(np.asarray(bridge.from_um(s))) <= 1e-12 * (1 + k))


modes = st.lists(
    st.tuples(st.floats(1.0, 1e5), st.floats(1.01, 3.0), st.floats(3.5, 15.0)),
    min_size=1,
    max_size=4,
)


@settings(max_examples=40, deadline=None)
@given(modes, freqs)
def test_amd_response_and_statespace_equal_the_controller(ms, f):
    cd = amd_controller(ms)
    s = 2j * np.pi * np.array([f, 0.1 * f, 10 * f])
    want = np.asarray(cd(s)).ravel()
    np.testing.assert_allclose(amd_response(ms, s), want, rtol=1e-9)
    A, B, C, D = amd_statespace(ms)
    via_ss = (C @ np.linalg.solve(s[:, None, None] * np.eye(A.shape[0]) - A, B))[:, 0, 0] + D[0, 0]
    np.testing.assert_allclose(via_ss, want, rtol=1e-7)  # a solve per point: cond(sI - A)


def test_amd_mode_damping_equals_the_python_control_path():
    plant = pzt_active_suspension()
    for ms in ([(5461, 2, 10), (6074, 2, 10), (9103, 2, 10)], [(9103, 2.5, 6)]):
        want = mode_damping(plant.to_statespace(), amd_controller(ms), [m[0] for m in ms])
        got = amd_mode_damping(plant, ms)
        assert got.stable == want.stable
        for name in ("freq_hz", "open_db", "damped_db", "attenuation_db", "estimate_db"):
            np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-12,
                                       atol=1e-12)  # fmt: skip


gains = st.floats(-1e3, 1e3).filter(lambda g: abs(g) > 1e-3)


@settings(max_examples=25, deadline=None)
@given(st.floats(1e2, 1e5), st.floats(1e-6, 0.2), gains, modes)
def test_amd_closed_loop_stability_agrees_with_python_control(fn, zeta, gain, ms):
    """Lightly damped single modes of either sign of residue: the stability verdict of
    the numpy closed loop is python-control's, unless a pole sits on the axis to ~1e-9."""
    plant = ModalPlant(gain=1.0, modes=(Mode(fn, zeta, gain * fn * fn),))
    closed = control.feedback(plant.to_statespace(), amd_controller(ms))
    poles = np.asarray(control.poles(closed))
    margin = np.max(poles.real) / np.max(np.abs(poles))
    if abs(margin) > 1e-9:
        assert amd_mode_damping(plant, ms).stable == bool(margin < 0)


def test_amd_mode_damping_refuses_a_delay_and_no_modes():
    plant = pzt_active_suspension().replace(delay=1e-6)
    with pytest.raises(ServokitValueError, match="delay"):
        amd_mode_damping(plant, [(5461, 2, 10)])
    with pytest.raises(ServokitValueError, match="empty"):
        amd_statespace([])
    with pytest.raises(ServokitValueError, match="kappa"):
        amd_response([(5461, 2, 1)], 1j)
