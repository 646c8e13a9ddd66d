"""Pole-zero IVC on an optical-disk focus servo (book §3.4.3, (3.101)-(3.104)).

The book prints the IVC matrix alpha (3.104) of its Blu-ray focus servo, which maps the
actuator's initial position and velocity to the two controller states and puts zeros of
the initial responses at z = 0.96416 and 0.95975 (undesirable closed-loop poles); the
loop itself is not printed. A gain matrix only has a meaning in given controller
coordinates, so alpha is "applied as given" here on a loop designed for it:

- focus actuator: mass-spring ``y'' + 2 zeta w0 y' + w0^2 y = g u`` (40 Hz, zeta 0.1,
  assumed), states [y, v], sampled at 10 us (assumed);
- the high-gain servo controller with complex zeros: an integrator and one more pole,
  placed by the Diophantine equation so that the closed loop has the book's two poles
  and two assumed faster ones (0.6 +- 0.3j);
- its state coordinates are then chosen (T = alpha K^-1 with K the pole-zero gain in the
  designed coordinates) so that alpha itself is the pole-zero IVC gain.

Shown: with alpha loaded, the initial responses from y(0) and v(0) have zeros at the two
printed poles; the initial responses for y(0) = +-78 and +-39 nm with and without IVC
(Figs. 3.34/3.35).
"""

from __future__ import annotations

import time
from pathlib import Path

import control
import numpy as np

from servokit.cases import register
from servokit.report import CaseResult, Comparison, nearest
from servokit.switching import (
    SwitchedLoop,
    free_response,
    ivc_pole_zero,
    ivc_zeros,
    place_controller,
    switched_loop,
)
from servokit.switching.plots import transient_plot

__all__ = ["switching_optical_case", "focus_loop", "ALPHA_3_104"]

ALPHA_3_104 = np.array([[1.6940e4, 1.0276e-1], [3.1543e5, -8.4265]])
POLES_TEXT = ("0.96416", "0.95975")
DT = 10e-6  # s, assumed


def focus_loop() -> SwitchedLoop:
    """The designed focus loop in the controller coordinates where alpha is the IVC gain."""
    w0, zeta, g = 2 * np.pi * 40.0, 0.1, 1.0
    a = np.array([[0.0, 1.0], [-(w0**2), -2 * zeta * w0]])
    plant = control.c2d(control.ss(a, [[0.0], [g]], [[1.0, 0.0]], 0), DT, "zoh")
    poles = [float(p) for p in POLES_TEXT] + [0.6 + 0.3j, 0.6 - 0.3j]
    ctrl = control.ss(place_controller(plant, poles, order=2, fixed_poles=[1.0]))
    loop = switched_loop(plant, ctrl)
    K = ivc_pole_zero(loop, None, [float(p) for p in POLES_TEXT])
    T = ALPHA_3_104 @ np.linalg.inv(K)  # xc' = T xc makes the IVC gain T K = alpha
    Ti = np.linalg.inv(T)
    return switched_loop(plant, control.ss(T @ ctrl.A @ Ti, T @ ctrl.B, ctrl.C @ Ti, ctrl.D, DT))


@register("switching-optical", order=120)
def switching_optical_case(outdir: Path) -> CaseResult:
    """alpha of (3.104) on a focus loop designed for it: zeros at the assigned poles."""
    start = time.perf_counter()
    loop = focus_loop()
    K = ivc_pole_zero(loop, None, [float(p) for p in POLES_TEXT])
    rows = []
    for state, name in ((0, "y(0)"), (1, "v(0)")):
        z = np.real(ivc_zeros(loop, ALPHA_3_104, state))
        for text in POLES_TEXT:
            rows.append(
                Comparison.printed(
                    f"zero of {name} -> y with alpha (3.104)",
                    text,
                    nearest(z, float(text)),
                    source="§3.4.3 (3.104)",
                    kind="consistency",
                    note="controller coordinates chosen so that alpha is the pole-zero gain of "
                    "the designed loop (40 Hz actuator, 10 us, poles 0.6 +- 0.3j assumed)",
                )
            )
    rows.append(
        Comparison(
            "max |pole-zero gain - alpha| / |alpha|",
            0.0,
            float(np.max(np.abs(K - ALPHA_3_104) / np.abs(ALPHA_3_104))),
            "",
            1e-6,
            "§3.4.3 (3.103)",
            kind="consistency",
            note="(3.103) solved on the designed loop returns alpha",
        )
    )
    n = 80
    t = np.arange(n) * DT * 1e3
    panels = []
    for label, gain in (
        ("without IVC (Fig. 3.34)", np.zeros((2, 2))),
        ("with IVC (Fig. 3.35)", ALPHA_3_104),
    ):
        curves = {
            f"y(0) = {y0:+g} nm": free_response(
                loop.A, loop.C, loop.stack(gain) @ np.array([y0, 0.0]), n
            )[:, 0]
            for y0 in (78.0, 39.0, -39.0, -78.0)
        }
        panels.append((label, curves))
    fig = transient_plot(
        t,
        panels,
        xlabel="Time [ms]",
        ylabel="Focus error [nm]",
        title="Figs. 3.34/3.35: initial responses of the focus servo (designed loop)",
        path=outdir / "fig3_35_focus_ivc.png",
    )
    return CaseResult(
        name="switching-optical",
        title="Pole-zero IVC on an optical-disk focus servo (§3.4.3)",
        comparisons=rows,
        figures=[fig],
        extra={"runtime_s": time.perf_counter() - start},
        chapter=3,
    )
