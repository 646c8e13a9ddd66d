"""Bring python-control plants into servokit: LTI systems as :class:`ModalPlant`.

The simulator, the seek search and the sampled-data sensitivity work on the book's
universal model (1.1)/(2.73),

    P(s) = sum_i A_i / (s^2 + 2 zeta_i w_i s + w_i^2) * exp(-s Td),

which python-control cannot express (no dead time in a ``StateSpace``).  A continuous
SISO ``StateSpace`` or ``TransferFunction`` is accepted when it *is* such a sum:

1. the poles (eigenvalues of ``A``) give the modes: a complex pair ``-zeta w +- j w
   sqrt(1 - zeta^2)`` one mode, a double pole at 0 the rigid body ``A_0 / s^2``;
2. the residues ``A_i`` are the real least-squares solution of ``P(j w_k) = sum_i A_i
   b_i(j w_k)`` on frequencies around every mode (the eigenvalues of a defective rigid-body
   block are not reliable enough for residue formulas, a linear fit over known bases is);
3. the fit must reproduce ``P`` to ``rtol`` everywhere on the grid, otherwise the system
   has a numerator term in ``s`` per mode, a real pole or a direct feed-through and is
   refused with the reason.

``delay`` adds the input dead time the python-control object cannot hold.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.models.modal import ModalPlant, Mode

__all__ = ["as_modal_plant", "as_modal_plants"]

# eigenvalues below this fraction of the largest pole magnitude are the rigid body's
_ZERO_POLE = 1e-9
# frequencies per mode in the residue fit (around the resonance and a decade either side)
_FIT_OFFSETS = (0.1, 0.7, 1.01, 1.4, 10.0)


def _is_lti(obj: object) -> bool:
    # a python-control object exists only once python-control is imported: asking
    # sys.modules keeps a ModalPlant-only run from paying that import (issue 23 start-up)
    control = sys.modules.get("control")
    return control is not None and isinstance(obj, control.LTI)


def _checked_ss(sys: Any) -> Any:
    """The continuous SISO state space of ``sys``, or a ServokitTypeError saying why not."""
    import control

    if not _is_lti(sys):
        raise ServokitTypeError(
            f"plant must be a ModalPlant or a python-control StateSpace/TransferFunction, "
            f"got {type(sys).__name__}"
        )
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise ServokitTypeError("plant must be SISO (one input, one output)")
    if sys.dt not in (0, None):
        raise ServokitTypeError(
            f"plant must be continuous (dt = 0), got dt = {sys.dt}; servokit discretises "
            "the continuous plant itself (exactly, delay included)"
        )
    ss = control.ss(sys)
    if np.any(np.asarray(ss.D) != 0):
        raise ServokitValueError("plant has a direct feed-through D != 0; it is not a modal sum")
    return ss


def _modes_from_poles(poles: np.ndarray) -> tuple[list[tuple[float, float]], int]:
    """(freq_hz, damping) per complex pair and the number of poles at the origin."""
    scale = max(float(np.max(np.abs(poles))), 1.0)
    at_zero = np.abs(poles) <= _ZERO_POLE * scale
    n_zero = int(np.count_nonzero(at_zero))
    rest = poles[~at_zero]
    real = rest[np.abs(rest.imag) <= _ZERO_POLE * scale]
    if real.size:
        raise ServokitValueError(
            f"plant has a real pole at {real[0].real:.6g} rad/s; only second-order modes "
            "with complex poles and the rigid body (double pole at 0) form a ModalPlant"
        )
    upper = rest[rest.imag > 0]
    modes = [(abs(p) / (2 * np.pi), -p.real / abs(p)) for p in upper]
    return sorted(modes), n_zero


def _fit_residues(ss: Any, modes: list[tuple[float, float]], rigid: bool, rtol: float):
    """Real residues of the modal bases fitted to the response of ``ss``; checked."""
    w = np.array([2 * np.pi * f for f, _ in modes])
    z = np.array([d for _, d in modes])
    anchors = np.concatenate([w, [1.0]]) if w.size else np.array([1.0])
    omega = np.unique(np.concatenate([a * np.array(_FIT_OFFSETS) for a in anchors]))
    s = 1j * omega
    H = np.asarray(ss(s)).ravel()
    bases = [1.0 / (s * s + 2 * zi * wi * s + wi * wi) for wi, zi in zip(w, z, strict=True)]
    if rigid:
        bases.insert(0, 1.0 / (s * s))
    if not bases:
        raise ServokitValueError("plant has no modes (no poles)")
    M = np.stack(bases, axis=1)
    # real unknowns: stack real and imaginary parts, rows scaled by |H| (relative fit)
    weight = 1.0 / np.maximum(np.abs(H), np.finfo(float).tiny)
    Mw, Hw = M * weight[:, None], H * weight
    A, *_ = np.linalg.lstsq(np.vstack([Mw.real, Mw.imag]), np.r_[Hw.real, Hw.imag], rcond=None)
    err = np.max(np.abs(Mw @ A - Hw))
    if np.isfinite(err) and rtol < err <= _ROUNDING_MISFIT:
        # the structure fits; the digits do not: a transfer function's polynomials of a
        # high-order plant round its modes (the galvano scanner: 1.5e-6)
        raise ServokitValueError(
            f"plant is a sum of modes up to a relative misfit of {err:.2e} > rtol {rtol:g}: "
            "rounding in the system's coefficients (a transfer function's polynomials lose "
            "digits); convert its state-space form, or pass a larger rtol"
        )
    if not np.isfinite(err) or err > rtol:
        raise ServokitValueError(
            f"plant is not a sum of modes A_i / (s^2 + 2 zeta w s + w^2) (relative misfit "
            f"{err:.2e} > {rtol:g}): a numerator term in s per mode or a single pole at 0 "
            "cannot be represented; use a python-control simulation for it"
        )
    return A


#: A relative misfit of the modal fit below this is rounding of the system's
#: coefficients, not a structure the modal sum cannot hold (those miss by 1e-2 and more).
_ROUNDING_MISFIT = 1e-4


def as_modal_plant(
    plant: Any, delay: float = 0.0, *, name: str = "", rtol: float = 1e-6
) -> ModalPlant:
    """A :class:`ModalPlant` equal to a python-control continuous SISO plant (plus a delay).

    Parameters
    ----------
    plant : ModalPlant, control.StateSpace or control.TransferFunction
        A ``ModalPlant`` is returned unchanged (``delay`` must then be 0); a python-control
        system must be continuous, SISO, strictly proper and a sum of second-order modes
        with constant numerators (eq. 1.1), optionally with a rigid body ``A_0 / s^2``.
    delay : float
        Input dead time Td [s] to add (python-control systems hold none).
    name : str
        Name of the result.
    rtol : float
        Largest relative misfit of the modal fit accepted on the fit grid.

    Returns
    -------
    ModalPlant
        ``gain`` is the largest residue magnitude; residues are relative to it.

    Raises
    ------
    ServokitTypeError
        Not a ModalPlant or python-control LTI, MIMO, or discrete.
    ServokitValueError
        A system that is not such a modal sum (the message says what is in the way).
    """
    if isinstance(plant, ModalPlant):
        if delay:
            raise ServokitValueError(
                "delay is only for python-control plants; a ModalPlant "
                "carries its own (use plant.replace(delay=...))"
            )
        return plant
    ss = _checked_ss(plant)
    modes, n_zero = _modes_from_poles(np.linalg.eigvals(np.asarray(ss.A, dtype=float)))
    if n_zero not in (0, 2):
        raise ServokitValueError(
            f"plant has {n_zero} pole(s) at the origin; a ModalPlant holds the rigid body "
            "1/s^2 (two) or none"
        )
    A = _fit_residues(ss, modes, n_zero == 2, rtol)
    gain = float(np.max(np.abs(A)))
    params = ([(0.0, 0.0)] if n_zero == 2 else []) + modes
    return ModalPlant(
        gain,
        tuple(Mode(f, d, float(a) / gain) for (f, d), a in zip(params, A, strict=True)),
        delay=delay,
        name=name or "python-control plant",
        source="converted from python-control",
    )


def as_modal_plants(plants: Any, delay: float = 0.0) -> list[ModalPlant]:
    """:func:`as_modal_plant` on one plant or each of a sequence (``delay`` added to each).

    Parameters
    ----------
    plants : ModalPlant, python-control LTI, or a sequence of them
        The plant set.
    delay : float
        Input dead time [s] added to each python-control plant.

    Returns
    -------
    list of ModalPlant
    """
    if isinstance(plants, ModalPlant) or _is_lti(plants):
        return [as_modal_plant(plants, delay)]
    if isinstance(plants, str | bytes) or not isinstance(plants, Sequence | np.ndarray):
        raise ServokitTypeError(
            "plants must be a ModalPlant, a python-control StateSpace/TransferFunction or a "
            f"sequence of them, got {type(plants).__name__}"
        )
    return [as_modal_plant(p, delay) for p in plants]
