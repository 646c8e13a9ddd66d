"""Self-sensing actuation bridges and active mode damping (book §5.4.2-§5.4.3)."""

from __future__ import annotations

import control
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.ssa import (
    amd_controller,
    amd_mode,
    ddssa_bridge,
    idssa_bridge,
    mode_damping,
)
from servokit.models import pzt_active_suspension

s = sp.symbols("s")


def _nodal(netlist, fixed, unknown):
    """Node voltages of an RC netlist by KCL (sympy): ``netlist`` = [(node_a, node_b,
    admittance)], ``fixed`` = {node: voltage expression}, ``unknown`` = node names."""
    v = {n: sp.Symbol(f"V_{n}") for n in unknown}
    volt = {**fixed, **v, "gnd": 0}
    eqs = []
    for n in unknown:
        current = 0
        for a, b, y in netlist:
            if n in (a, b):
                other = b if a == n else a
                current += y * (volt[n] - volt[other])
        eqs.append(sp.Eq(current, 0))
    sol = sp.solve(eqs, list(v.values()), dict=True)[0]
    return {n: sp.simplify(sol[v[n]]) for n in unknown}


def _ddssa_circuit(cp, c1, c2, c3, r1=None, r3=None):
    um, vm = sp.symbols("u_M v_M")
    y1 = s * c1 + (0 if r1 is None else 1 / sp.nsimplify(r1))
    y3 = s * c3 + (0 if r3 is None else 1 / sp.nsimplify(r3))
    # the PZT: source vM in series with CPZT, from uM to v1 (node a = uM - vM)
    net = [("a", "v1", s * cp), ("v1", "gnd", y1), ("um", "v2", s * c2), ("v2", "gnd", y3)]
    nodes = _nodal(net, {"um": um, "a": um - vm}, ["v1", "v2"])
    vs = sp.expand(nodes["v2"] - nodes["v1"])
    return sp.simplify(sp.diff(vs, um)), sp.simplify(sp.diff(vs, vm))


def _tf_at(expr, f):
    return complex(expr.subs(s, 2j * sp.pi * f).evalf())


caps = st.floats(0.2, 5.0)


@settings(max_examples=6, deadline=None)
@given(caps, caps, caps, caps, st.booleans())
def test_ddssa_against_nodal_analysis(cp, c1, c2, c3, resistors) -> None:
    scale = 1e-9  # nF
    r = (2e3, 3e3) if resistors else (None, None)
    bridge = ddssa_bridge(cp * scale, c1 * scale, c2 * scale, c3 * scale, r1=r[0], r3=r[1])
    from_um, from_vm = _ddssa_circuit(
        *(sp.nsimplify(x) * sp.Rational(1, 10**9) for x in (cp, c1, c2, c3)), *r
    )
    for f in (50.0, 2e3, 1e5):
        w = 2j * np.pi * f
        assert complex(bridge.from_um(w)) == pytest.approx(_tf_at(from_um, f), rel=1e-6, abs=1e-9)
        assert complex(bridge.from_vm(w)) == pytest.approx(_tf_at(from_vm, f), rel=1e-6)


def test_ddssa_balance_and_printed_sign() -> None:
    cp = 2e-9
    b = ddssa_bridge(cp, cp, cp, cp)
    assert b.balanced
    assert abs(complex(b.from_um(1j * 1e4))) < 1e-12
    assert complex(b.from_vm(1j * 1e4)) == pytest.approx(0.5)  # (5.62): vs = vM / 2
    # off balance the uM coefficient is C2/(C2+C3) - CPZT/(C1+CPZT), opposite to (5.61)
    c1, c2, c3 = 1e-9, 3e-9, 1e-9
    b = ddssa_bridge(cp, c1, c2, c3)
    assert not b.balanced
    assert complex(b.from_um(1j)).real == pytest.approx(c2 / (c2 + c3) - cp / (c1 + cp))
    # general balance CPZT C3 = C1 C2 with unequal parts, resistors CPZT/R3 = C2/R1
    b = ddssa_bridge(2e-9, 1e-9, 4e-9, 2e-9, r1=8e3, r3=4e3)
    assert b.balanced and abs(complex(b.from_um(2j * np.pi * 300))) < 1e-12


@settings(max_examples=30, deadline=None)
@given(
    st.floats(0.3, 3.0),
    st.floats(0.3, 3.0),
    st.floats(0.5, 5.0),
    st.floats(0.5, 5.0),
    st.floats(0.5, 10.0),
)
def test_idssa_balanced_is_the_highpass_of_5_66(cp, c2r, r1, r2, k) -> None:
    c = cp * 1e-9
    r = (r1 * 1e3, r2 * 1e3)
    b = idssa_bridge((c, c, c, c), c, c, (r[0], r[1], r[0], r[1], 1e3, k * 1e3, k * 1e3, 1e3))
    wc = 2 * np.pi * b.fc_hz
    hp = control.tf([k, 0, 0], [1, 2 * b.damping * wc, wc**2])
    for f in (0.1 * b.fc_hz, b.fc_hz, 10 * b.fc_hz):
        w = 2j * np.pi * f
        assert abs(complex(b.from_um(w))) < 1e-9
        assert complex(b.from_vm(w)) == pytest.approx(complex(hp(w)), rel=1e-8)
    # fc and zeta of (5.66) are those of the denominator's roots (independent check)
    den = np.array([c * c * r[0] * r[1], 3 * c * r[0], 1.0])
    roots = np.roots(den)
    wn = np.sqrt(np.prod(roots).real)
    assert wn == pytest.approx(wc, rel=1e-9)
    assert -np.sum(roots).real / (2 * wn) == pytest.approx(b.damping, rel=1e-9)
    assert b.gain == pytest.approx(k)


def test_amd_reading_of_5_67() -> None:
    f, eps, kappa = 5e3, 2.0, 10.0
    cd = amd_mode(f, eps, kappa)
    assert abs(complex(cd(0))) == pytest.approx(1.0)  # KD = eps: unit DC gain
    assert abs(complex(cd(1e9j))) == pytest.approx(eps, rel=1e-4)
    # phase at wn: atan(eps) - 45 deg; poles: a pair at wn, damping (kappa/eps + eps/kappa)/2
    assert np.angle(complex(cd(2j * np.pi * f))) == pytest.approx(np.arctan(eps) - np.pi / 4)
    p = np.sort(np.real(control.poles(cd)))
    assert np.prod(p) == pytest.approx((2 * np.pi * f) ** 2, rel=1e-9)
    zeta = -np.sum(p) / (2 * 2 * np.pi * f)
    assert zeta == pytest.approx((kappa / eps + eps / kappa) / 2, rel=1e-9)
    with pytest.raises(ServokitValueError, match="kappa"):
        amd_mode(f, 3.0, 2.0)


def test_amd_damps_the_pzt_modes() -> None:
    plant = pzt_active_suspension().to_statespace()
    modes = [(5461, 2.0, 10.0), (6074, 2.0, 10.0), (9103, 2.0, 10.0)]
    res = mode_damping(plant, amd_controller(modes), [m[0] for m in modes])
    assert res.stable
    assert np.all(res.attenuation_db > 2.0)
    # independent: closed-loop response from python-control's feedback
    closed = control.feedback(plant, amd_controller(modes))
    grid = np.linspace(0.9 * 9103, 1.1 * 9103, 2001)
    peak = np.abs(np.asarray(closed(2j * np.pi * grid)).ravel()).max()
    assert 20 * np.log10(peak) == pytest.approx(res.damped_db[2], abs=1e-6)


def test_bad_input() -> None:
    with pytest.raises(ServokitValueError, match="c1"):
        ddssa_bridge(1e-9, -1e-9, 1e-9, 1e-9)
    with pytest.raises(ServokitValueError, match="r1 and r3"):
        ddssa_bridge(1e-9, 1e-9, 1e-9, 1e-9, r1=1e3)
    with pytest.raises(ServokitValueError, match="modes"):
        amd_controller([])


def test_ssa_case(tmp_path) -> None:
    from servokit.cases.dual_stage import run_ssa

    res = run_ssa(tmp_path)
    assert all(c.ok for c in res.comparisons)
    assert res.extra["amd_stable"] and all(p.exists() for p in res.figures)
    assert res.chapter == 5
