"""The book's delayed HDD loops of §3.3.1-§3.3.2, rebuilt from their printed poles.

The book prints the closed-loop poles of its delayed HDD loops but not the loops.  The
structure it states (second-order mechanics, first-order Padé delay, ZOH, second-order
lead-lag) is rebuilt with the unknowns made explicit: Td/dt is fitted to the two plant
zeros printed in §3.3.2 (-56.79, -0.235) and the controller follows from the printed
closed-loop poles (Diophantine equation).  :func:`jmin_loop` is the rigid-body loop with a
250 Hz lead-lag of the J-min IVC figures (3.5/3.6).  The sampling period (150 us, the
book's §3.3.3 simulation) is assumed.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from servokit.models.rational import StateSpaceData
from servokit.switching.design import (
    fit_delay_ratio,
    lead_lag_data,
    pade_double_integrator_data,
    place_controller_data,
)
from servokit.switching.loop import SwitchedLoop, switched_loop

__all__ = [
    "DT",
    "POLES_331",
    "POLES_332",
    "RP_ZEROS_332",
    "book_loop",
    "delay_ratio",
    "expand_poles",
    "jmin_loop",
]


POLES_331 = ("-0.335", "0.555+0.416j", "0.905", "0.954")


POLES_332 = ("-0.323", "0.550+0.497j", "0.904", "0.955")


RP_ZEROS_332 = ("-56.79", "0.999", "-0.416", "-0.235")


#: assumed sampling period [s]: the 150 us the book states for its §3.3.3 HDD simulation
DT = 150e-6


def expand_poles(poles: tuple[str, ...] | list[complex]) -> list[complex]:
    """Printed poles as complex numbers, each complex one followed by its conjugate.

    Parameters
    ----------
    poles : sequence of str or complex
        Printed poles (a complex value stands for its conjugate pair too).

    Returns
    -------
    list of complex
        All poles.
    """
    out: list[complex] = []
    for p in poles:
        c = complex(p)
        out += [c, c.conjugate()] if c.imag else [c]
    return out


@lru_cache(maxsize=4)
def delay_ratio(plant_zeros: tuple[float, ...]) -> float:
    """Td/dt fitted to printed plant zeros (:func:`~servokit.switching.fit_delay_ratio`), cached.

    Parameters
    ----------
    plant_zeros : tuple of float
        Printed discrete plant zeros.

    Returns
    -------
    float
        The delay as a fraction of the sampling period.
    """
    return fit_delay_ratio(plant_zeros)


def book_loop(
    poles=POLES_332, plant_zeros=(-56.79, -0.235), dt: float = DT, ratio: float | None = None
) -> SwitchedLoop:
    """The fitted delayed HDD loop: Td/dt from ``plant_zeros``, controller from ``poles``.

    Plant states are [position, velocity, Padé state] with unit gain (so position in
    the unit of the initial state, velocity in that unit per second).

    Parameters
    ----------
    poles : sequence of str or complex
        Printed closed-loop poles (a complex value stands for its conjugate pair too).
    plant_zeros : sequence of float
        Printed plant zeros that fix Td/dt.
    dt : float
        Sampling period [s].
    ratio : float, optional
        Td/dt to use instead of the fit.

    Returns
    -------
    SwitchedLoop
        The closed loop of (3.17) (plant and controller matrices).
    """
    r = delay_ratio(tuple(plant_zeros)) if ratio is None else ratio
    plant = pade_double_integrator_data(dt, r * dt)  # numpy: python-control left unloaded
    return switched_loop(plant, place_controller_data(plant, expand_poles(poles)))


def jmin_loop(dt: float = DT, crossover_hz: float = 250.0) -> SwitchedLoop:
    """Rigid-body plant (states position [m], velocity [m/s]) with a lead-lag at 250 Hz.

    The loop of the J-min IVC figures (3.5/3.6); the lead-lag is designed here (assumed).

    Parameters
    ----------
    dt : float
        Sampling period [s].
    crossover_hz : float
        Crossover frequency of the lead-lag [Hz].

    Returns
    -------
    SwitchedLoop
        The closed loop of (3.17) (plant and controller matrices).
    """
    from servokit.models._zoh import zoh_pair

    # python-control's c2d(ss(...), dt, "zoh") arithmetic: expm([[A, B], [0, 0]] dt)
    phi, gam = zoh_pair(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]), dt)
    rigid = StateSpaceData(phi, gam, [[1.0, 0.0]], [[0.0]], dt)
    return switched_loop(rigid, lead_lag_data(rigid, crossover_hz))
