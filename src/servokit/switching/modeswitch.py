"""Mode switching and reference switching on a discrete loop (book §3.2, §3.4.1, §3.5).

Two kinds of switched operation, simulated sample by sample on the discrete loop of
(3.15)-(3.17) (the plant's state is known exactly, as the book assumes):

- :func:`mode_switching_response`: a seek phase drives the plant open loop with a
  given input sequence until a switching condition holds; the settling controller then
  closes the loop on the target with its state loaded by IVC,
  ``xc[0] = xc_ss + K (xp[0] - xp_ss)`` about the closed-loop equilibrium of the target
  (``K = None``: the controller state is reset to its equilibrium, the zero reset).
- :func:`reference_switching_response`: the reference steps while the loop is still
  moving (galvano back-and-forth, §3.5); at each step the additional input
  ``r' = sum_k n_k/d (x_k - x_k,ss)`` of an :class:`AdditionalInputIvc` design is
  superposed for the chosen plant states. ``x_ss`` is the equilibrium of the previous
  reference: the residual of the previous motion (§3.5.1.1) is what gets compensated,
  while the designed step response from one equilibrium to the next is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_finite
from servokit.switching.additional import AdditionalInputIvc
from servokit.switching.loop import SwitchedLoop

__all__ = [
    "SwitchedResponse",
    "equilibrium",
    "mode_switching_response",
    "reference_switching_response",
]


@dataclass(frozen=True)
class SwitchedResponse:
    """Samples of a switched run: output ``y``, input ``u``, switch instants ``switches``."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    switches: tuple[int, ...]


def equilibrium(loop: SwitchedLoop, r: float) -> np.ndarray:
    """Closed-loop equilibrium ``x_ss = (I - A)^{-1} B r`` for a constant reference."""
    N = loop.n + loop.m
    M = np.eye(N) - loop.A
    if np.min(np.abs(1.0 - np.linalg.eigvals(loop.A))) < 1e-10:
        raise ServokitValueError("the closed loop has a pole at z = 1; no equilibrium exists")
    return np.linalg.solve(M, loop.B[:, 0] * r)


def mode_switching_response(
    loop: SwitchedLoop,
    seek_input: Sequence[float],
    target: float,
    switch_when: Callable[[np.ndarray, int], bool],
    K: np.ndarray | None,
    n_samples: int,
) -> SwitchedResponse:
    """Seek open loop with ``seek_input`` until ``switch_when(xp, k)``, then settle with IVC.

    Parameters
    ----------
    loop : SwitchedLoop
        The settling loop (plant and settling controller).
    seek_input : sequence of float
        Plant input during the seek (held by the plant's ZOH); the seek ends at the latest
        when it runs out.
    target : float
        Reference of the settling controller.
    switch_when : callable
        ``(xp, k) -> bool`` on the plant state, e.g. a distance/velocity condition.
    K : ndarray or None
        IVC gain (m x n); None resets the controller to its equilibrium state.
    n_samples : int
        Total number of samples simulated.
    """
    n_samples = check_count("n_samples", n_samples, lo=2)
    seek = check_finite("seek_input", seek_input).ravel()
    xp = np.zeros(loop.n)
    y, u = np.empty(n_samples), np.empty(n_samples)
    k = 0
    while k < n_samples and k < seek.size and not switch_when(xp, k):
        y[k], u[k] = loop.Cp[0] @ xp, seek[k]
        xp = loop.Ap @ xp + loop.Bp[:, 0] * seek[k]
        k += 1
    ss = equilibrium(loop, target)
    gain = np.zeros((loop.m, loop.n)) if K is None else np.asarray(K, dtype=float)
    x = np.concatenate([xp, ss[loop.n :] + gain @ (xp - ss[: loop.n])])
    switch = k
    for j in range(k, n_samples):
        y[j] = loop.C[0] @ x
        u[j] = loop.Cu[0] @ x + loop.Dr[0, 0] * target
        x = loop.A @ x + loop.B[:, 0] * target
    return SwitchedResponse(np.arange(n_samples) * loop.dt, y, u, (switch,))


def reference_switching_response(
    loop: SwitchedLoop,
    reference: Sequence[float],
    design: AdditionalInputIvc | None = None,
    states: Sequence[int] = (),
) -> SwitchedResponse:
    """Closed loop from rest following ``reference`` (one value per sample), with r' IVC.

    At every sample where the reference changes, the plant states ``states`` are read
    relative to the equilibrium of the previous reference (the residual of the previous
    motion) and ``design``'s compensators
    ``n_k/d`` are started with them (3.106); earlier compensations keep running, so
    each one still cancels its own initial values (superposition).
    """
    r = check_finite("reference", reference).ravel()
    n = r.size
    rp = np.zeros(n)
    x = equilibrium(loop, r[0])
    y, u, switches = np.empty(n), np.empty(n), []
    for k in range(n):
        if k > 0 and r[k] != r[k - 1]:
            switches.append(k)
            if design is not None:
                rp[k:] += _compensation(loop, design, states, x, r[k - 1], n - k)
        y[k] = loop.C[0] @ x
        u[k] = loop.Cu[0] @ x + loop.Dr[0, 0] * r[k] + rp[k]
        x = loop.A @ x + loop.B[:, 0] * r[k] + loop.Bu[:, 0] * rp[k]
    return SwitchedResponse(np.arange(n) * loop.dt, y, u, tuple(switches))


def _compensation(loop, design, states, x, r_old, length) -> np.ndarray:
    """r' for the residual of the previous motion: the state minus its equilibrium."""
    dev = x - equilibrium(loop, r_old)
    out = np.zeros(length)
    for k in states:
        out += dev[k] * design.impulse(k, length)
    return out
