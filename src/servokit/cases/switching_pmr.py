"""IVC at the four-wheel to inverted-pendulum switch of a personal mobility robot (§3.4.2).

The linearised wheeled-inverted-pendulum model (3.98) of the catalogue (illustrative
parameters: 80 kg rider and vehicle) without the wheel angle (it does not enter the
dynamics), states [eta, eta', theta'], outputs [eta, eta', theta' - eta'] (Fig. 3.29),
sampled at 2 ms (assumed). The book's fifth-order H-infinity controller is not printed;
here an observer-based LQ controller with integral action on the motor-velocity error
(4 states, designed by discrete Riccati equations) stands in for it. At the switch the
controller state is loaded by the J-min IVC of (3.99)-(3.100),
``xc[0] = Ka xp[0] + Kb r + Kc uw``, with state, input and jerk weights, or reset to
zero (no IVC). Switching state (assumed, cf. Fig. 3.30): inclination eta = 0.05 rad at
-0.3 rad/s, motor velocity half the 1.0 km/h target, step torque input before the
switch uw = 20 N m.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import control
import numpy as np
import scipy.linalg

from servokit.cases import register
from servokit.models import personal_mobility_robot
from servokit.report import CaseResult, Comparison
from servokit.switching import SwitchedLoop, equilibrium, ivc_jmin_jerk, switched_loop
from servokit.switching.plots import transient_plot

__all__ = ["switching_pmr_case", "pmr_loop"]

DT = 2e-3  # s, assumed
V_TARGET = 1.0 / 3.6  # 1.0 km/h in m/s
RW = 0.2  # wheel radius of the catalogue model [m]
UW = 20.0  # input just before the switch [N m], assumed
Q_U, Q_J = 1e-2, 1.0  # input and jerk weights of (3.99), assumed


def _plant() -> control.StateSpace:
    full = control.c2d(personal_mobility_robot(), DT, "zoh")
    keep = [0, 2, 3]  # eta, eta', theta' (the wheel angle theta does not act back)
    A = np.asarray(full.A)[np.ix_(keep, keep)]
    return control.ss(A, np.asarray(full.B)[keep], np.asarray(full.C)[:, keep], 0, DT)


def pmr_loop() -> SwitchedLoop:
    """Observer-based LQ controller with integral action on theta' - eta' (assumed)."""
    P = _plant()
    A, B, C = (np.asarray(M, dtype=float) for M in (P.A, P.B, P.C))
    e3 = np.array([[0.0, 0.0, 1.0]])
    Aa = np.block([[A, np.zeros((3, 1))], [-DT * e3 @ C, np.ones((1, 1))]])
    Ba = np.vstack([B, np.zeros((1, 1))])
    Xa = scipy.linalg.solve_discrete_are(Aa, Ba, np.diag([100.0, 1.0, 1.0, 10.0]), np.eye(1) * 1e-2)
    Ka = np.linalg.solve(1e-2 + Ba.T @ Xa @ Ba, Ba.T @ Xa @ Aa)
    Kx, Ki = Ka[:, :3], Ka[:, 3:]
    Xo = scipy.linalg.solve_discrete_are(A.T, C.T, np.eye(3) * 1e-2, np.eye(3) * 1e-4)
    L = np.linalg.solve(C @ Xo @ C.T + np.eye(3) * 1e-4, C @ Xo @ A.T).T
    Ac = np.block([[A - L @ C - B @ Kx, -B @ Ki], [np.zeros((1, 3)), np.ones((1, 1))]])
    By = np.vstack([L, -DT * e3])  # measurement path of the controller
    Br = np.vstack([np.zeros((3, 3)), DT * e3])  # reference: motor-velocity target only
    ctrl = control.ss(Ac, -By, np.hstack([-Kx, -Ki]), np.zeros((1, 3)), DT)  # driven by -y
    return dataclasses.replace(switched_loop(P, ctrl), Bcr=Br, Dcr=np.zeros((1, 3)))


def _run(loop: SwitchedLoop, xc0: np.ndarray, xp0: np.ndarray, r: np.ndarray, n: int):
    x = np.concatenate([xp0, xc0])
    y, u = np.empty((n, 3)), np.empty(n)
    for k in range(n):
        y[k], u[k] = loop.C @ x, loop.Cu[0] @ x + loop.Dr[0] @ r
        x = loop.A @ x + loop.B @ r
    return y, u


@register("switching-pmr", order=125)
def switching_pmr_case(outdir: Path) -> CaseResult:
    """Transients after the mode switch with and without IVC (cf. Fig. 3.30)."""
    start = time.perf_counter()
    loop = pmr_loop()
    r = np.array([0.0, 0.0, V_TARGET / RW])
    xp0 = np.array([0.05, -0.3, 0.5 * V_TARGET / RW - 0.3])  # theta' = motor vel. + eta'
    gains = ivc_jmin_jerk(loop, np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0]), Q_U, Q_J)
    n = 1000
    runs = {
        "with IVC": _run(loop, gains.state(xp0, r, UW), xp0, r, n),
        "without IVC": _run(loop, np.zeros(loop.m), xp0, r, n),
    }
    stats = {
        k: {
            "peak_u": float(np.max(np.abs(u))),
            "max_jerk": float(np.max(np.abs(np.diff(np.concatenate([[UW], u]))))),
            "eta_range": float(np.ptp(y[:, 0])),
        }
        for k, (y, u) in runs.items()
    }
    better = float(all(stats["with IVC"][q] < stats["without IVC"][q] for q in stats["with IVC"]))
    rows = [
        Comparison(
            "IVC lowers the input peak and the input jump at the switch (1 = yes)",
            1.0,
            better,
            "",
            0.0,
            "Fig. 3.30",
            kind="assumed",
            note="book: experiment; here an assumed LQ + observer controller on the "
            "illustrative model, "
            + ", ".join(
                f"{k}: peak u {v['peak_u']:.3g}, jump {v['max_jerk']:.3g}" for k, v in stats.items()
            ),
        )
    ]
    t = np.arange(n) * DT
    panels = [
        ("motor velocity (theta' - eta') [rad/s]", {k: y[:, 2] for k, (y, _) in runs.items()}),
        ("inclination eta [rad]", {k: y[:, 0] for k, (y, _) in runs.items()}),
        ("input u = n tau [N m]", {k: u for k, (_, u) in runs.items()}),
    ]
    fig = transient_plot(
        t,
        panels,
        xlabel="Time after the switch [s]",
        ylabel=("[rad/s]", "[rad]", "[N m]"),
        title="Fig. 3.30 (simulated): switch to the inverted-pendulum mode (assumed loop)",
        path=outdir / "fig3_30_pmr_ivc.png",
    )
    assert np.allclose(equilibrium(loop, 0.0), 0.0)
    return CaseResult(
        name="switching-pmr",
        title="IVC for a personal mobility robot (§3.4.2)",
        comparisons=rows,
        figures=[fig],
        extra={"stats": stats, "runtime_s": time.perf_counter() - start},
        chapter=3,
    )
