"""Multirate holds: interpolator, multirate filter and fast zero-order hold.

Implements the transfer characteristic of the multirate path of the book's Fig. 4.2

    W(j w) = Ip(e^{j w Ts/m}) Fm(e^{j w Ts/m}) Hm(j w),            eq. (4.26)
    Hm(s)  = (1 - e^{-s Ts/m}) / s,                                  eq. (4.66)

with the controller output up-sampled by ``m`` (zero insertion), filtered by the
interpolation filter ``Ip`` (e.g. ``1 + z^-1 + z^-2 + z^-3`` of eq. (4.67)) and the
multirate filter ``Fm`` at the fast rate ``Ts/m``, and held for ``Ts/m``.  With the
default interpolator ``1 + z^-1 + ... + z^-(m-1)`` and no filter the path is exactly a
zero-order hold at ``Ts`` (:func:`zoh_response`), so ``W = H`` of eq. (4.4).

It also builds the exact discrete-time model from ``ud`` to ``yd`` at ``Ts``, i.e. the
controlled object ``Pdm`` of eq. (4.25) as a state-space model, by lifting the fast-rate
exact ZOH discretisation of the plant over one slow period.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitTypeError, ServokitValueError, check_positive
from servokit.models.modal import ModalPlant
from servokit.models.rational import (
    RationalTF,
    StateSpaceData,
    as_state_space_data,
    series,
)
from servokit.models.tf import require_proper

__all__ = ["Multirate", "zoh_response", "eval_discrete", "check_discrete"]

_HOLDS = ("zoh",)


def zoh_response(freq_hz: np.ndarray, hold_time: float) -> np.ndarray:
    """Frequency response ``(1 - e^{-j w T}) / (j w)`` of a zero-order hold of length ``T``.

    Used as ``H`` in eq. (4.4) and ``Hm`` in eq. (4.66); the value at ``w = 0`` is ``T``.

    Parameters
    ----------
    freq_hz : array_like
        Frequencies [Hz], any shape.
    hold_time : float
        Hold length ``T`` [s].

    Returns
    -------
    ndarray of complex, same shape as ``freq_hz``; its unit is seconds.
    """
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    x = w * hold_time
    # T e^{-jx/2} sinc(x/2): no 0/0 at w = 0 and no cancellation for small w
    return hold_time * np.exp(-0.5j * x) * np.sinc(x / (2.0 * np.pi))


def _is_lti(sys: object) -> bool:
    """A python-control LTI or its numpy-only form (no python-control import for those)."""
    if isinstance(sys, RationalTF | StateSpaceData):
        return True
    return isinstance(sys, control.TransferFunction | control.StateSpace)


def _is_tf(sys: object) -> bool:
    if isinstance(sys, RationalTF | StateSpaceData):
        return isinstance(sys, RationalTF)
    return isinstance(sys, control.TransferFunction)


def _to_control(sys: object) -> control.LTI:
    return sys.to_control() if isinstance(sys, RationalTF | StateSpaceData) else sys


def _lti(name: str, sys: object) -> control.LTI:
    if not _is_lti(sys):
        raise ServokitTypeError(
            f"{name} must be a discrete python-control TransferFunction or StateSpace "
            f"(or servokit RationalTF/StateSpaceData), got {type(sys).__name__}"
        )
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise ServokitValueError(f"{name} must be SISO (got {sys.noutputs}x{sys.ninputs})")
    require_proper(name, sys)
    sys_dt = sys.dt
    # dt=True is python-control's "discrete, period unspecified": unusable here
    if sys_dt is None or isinstance(sys_dt, bool) or float(sys_dt) <= 0:
        raise ServokitValueError(
            f"{name} must be discrete with a numeric sampling period; discretise it first "
            "(e.g. control.sample_system(sys, dt, method='tustin'))"
        )
    return sys


def check_discrete(name: str, sys: object, dt: float) -> control.LTI:
    """Return ``sys`` if it is a SISO discrete python-control LTI with sampling period ``dt``.

    Parameters
    ----------
    name : str
        The system's name in the error messages (``"controller"``, ``"filter"``).
    sys : control.TransferFunction, control.StateSpace, RationalTF or StateSpaceData
        System to check; it must also be proper.
    dt : float
        Required sampling period [s] (matched to a relative 1e-9).

    Returns
    -------
    control.TransferFunction or control.StateSpace
        ``sys`` itself.

    Raises
    ------
    ServokitTypeError
        If ``sys`` is not a python-control ``TransferFunction``/``StateSpace``.
    ServokitValueError
        If it is continuous, MIMO, or has another sampling period.
    """
    sys = _lti(name, sys)
    if not np.isclose(float(sys.dt), dt, rtol=1e-9, atol=0.0):
        raise ServokitValueError(
            f"{name} has dt = {float(sys.dt):.6g} s but {dt:.6g} s is required; "
            "resample it at the required period"
        )
    return sys


def _shifted(z: np.ndarray, A: np.ndarray) -> np.ndarray:
    """``z[k] I - A`` for every point (k, n, n): ``-A`` copied, ``z`` added on the
    diagonal (the values of ``z[:, None, None] * eye - A`` at a third of the cost)."""
    n = A.shape[0]
    out = np.empty((z.size, n, n), dtype=complex)
    out[:] = -A
    out.reshape(z.size, n * n)[:, :: n + 1] += z[:, None]
    return out


def eval_discrete(sys: control.LTI, z: np.ndarray) -> np.ndarray:
    """Evaluate a SISO discrete LTI at the complex points ``z`` (any shape).

    State-space models are evaluated as ``C (zI - A)^-1 B + D`` by batched linear solves
    (no inverse, no conversion to a polynomial ratio, which is ill-conditioned for
    the high-order lifted models); a point on a pole gives ``inf``.

    Parameters
    ----------
    sys : control.TransferFunction, control.StateSpace, RationalTF or StateSpaceData
        SISO discrete system (not checked; see :func:`check_discrete`).
    z : array_like of complex
        Points of the z-plane, any shape (``exp(j 2 pi f dt)`` for a frequency response).

    Returns
    -------
    ndarray of complex, same shape as ``z``
        ``sys(z)``: ``num(z) / den(z)`` for a transfer function, ``C (zI - A)^-1 B + D``
        for a state-space model.
    """
    z = np.asarray(z, dtype=complex)
    if _is_tf(sys):
        num = np.asarray(sys.num[0][0], dtype=float)
        den = np.asarray(sys.den[0][0], dtype=float)
        return np.polyval(num, z) / np.polyval(den, z)
    A, B, C, D = (np.asarray(x, dtype=float) for x in (sys.A, sys.B, sys.C, sys.D))
    flat = z.reshape(-1)
    out = np.empty(flat.size, dtype=complex)
    n = A.shape[0]
    step = max(1, 4_000_000 // max(n * n, 1))
    eye = np.eye(n)
    for i in range(0, flat.size, step):
        zz = flat[i : i + step]
        try:
            x = np.linalg.solve(_shifted(zz, A), np.broadcast_to(B, (zz.size, n, 1)))
            out[i : i + step] = (C @ x)[:, 0, 0] + D[0, 0]
        except np.linalg.LinAlgError:
            for j, zj in enumerate(zz):
                try:
                    out[i + j] = (C @ np.linalg.solve(zj * eye - A, B))[0, 0] + D[0, 0]
                except np.linalg.LinAlgError:
                    out[i + j] = np.inf
    return out.reshape(z.shape)


@dataclass(frozen=True)
class Multirate:
    """Multirate path of Fig. 4.2: up-sampler by ``m``, ``Ip``, ``Fm`` and a hold at ``Ts/m``.

    Parameters
    ----------
    m : int
        Multirate number (>= 1): the fast rate is ``m`` times the controller rate.
    interpolator : control.TransferFunction, control.StateSpace or RationalTF, optional
        Interpolation filter ``Ip`` at ``dt/m`` (eq. 4.67).  ``None`` means the hold
        interpolator ``1 + z^-1 + ... + z^-(m-1)``, which with no ``filter`` makes the
        path an ordinary zero-order hold at ``dt``.  There is no ``1/m`` gain: the
        up-sampler inserts zeros, the interpolator repeats the sample.
    filter : control.TransferFunction, control.StateSpace or RationalTF, optional
        Multirate filter ``Fm`` at ``dt/m`` (e.g. eq. (4.68) discretised); ``None`` = 1.
    hold : {"zoh"}
        The fast hold ``Hm`` (eq. 4.66).  Only the zero-order hold is implemented.
    """

    m: int
    interpolator: control.LTI | None = None
    filter: control.LTI | None = None
    hold: str = "zoh"

    def __post_init__(self) -> None:
        if isinstance(self.m, bool) or not isinstance(self.m, int | np.integer):
            raise ServokitTypeError(f"m must be an integer multirate number, got {self.m!r}")
        if self.m < 1:
            raise ServokitValueError(f"m must be >= 1 (got {self.m}); use m = 1 for single rate")
        object.__setattr__(self, "m", int(self.m))
        if self.hold not in _HOLDS:
            raise ServokitValueError(f"hold must be one of {_HOLDS} (got {self.hold!r})")
        fast = {self._own_dt(name) for name in ("interpolator", "filter")} - {None}
        if len(fast) > 1:
            raise ServokitValueError(
                "interpolator and filter must have the same sampling period (dt/m); "
                f"got {sorted(fast)}"
            )

    def _own_dt(self, name: str) -> float | None:
        sys = getattr(self, name)
        return None if sys is None else float(_lti(name, sys).dt)

    # ------------------------------------------------------------------ pieces
    def fast_dt(self, dt: float) -> float:
        """Fast period ``dt/m``, checking that the filters were designed for it."""
        dt = check_positive("dt", dt, "seconds")
        h = dt / self.m
        for name in ("interpolator", "filter"):
            sys = getattr(self, name)
            if sys is not None:
                check_discrete(name, sys, h)
        return h

    def interpolator_tf(self, dt: float) -> control.LTI:
        """``Ip`` at ``dt/m`` (the hold interpolator when none was given), python-control."""
        return _to_control(self._interpolator(dt))

    def _interpolator(self, dt: float) -> object:
        h = self.fast_dt(dt)
        if self.interpolator is not None:
            return self.interpolator
        return RationalTF(np.ones(self.m), np.r_[1.0, np.zeros(self.m - 1)], h)

    def chain(self, dt: float) -> control.LTI:
        """The fast-rate filter ``Ip Fm`` at ``dt/m`` (what follows the zero insertion).

        This is the ``F`` of ``servokit.simulate.simulate(..., multirate=(m, F))``.
        """
        return _to_control(self._chain(dt))

    def _chain(self, dt: float) -> object:
        """:meth:`chain` as given: numpy-only when ``Ip`` and ``Fm`` are RationalTF."""
        ip = self._interpolator(dt)
        if self.filter is None:
            return ip
        if isinstance(ip, RationalTF) and isinstance(self.filter, RationalTF):
            return self.filter * ip  # python-control's series(ip, filter) = filter * ip
        return control.series(_to_control(ip), _to_control(self.filter))

    # --------------------------------------------------------------- responses
    def filter_response(self, freq_hz: np.ndarray, dt: float) -> np.ndarray:
        """``Ip(e^{j w dt/m}) Fm(e^{j w dt/m})`` at ``freq_hz`` (any shape), complex."""
        h = self.fast_dt(dt)
        f = np.asarray(freq_hz, dtype=float)
        z = np.exp(2j * np.pi * f * h)
        out = eval_discrete(self._interpolator(dt), z)
        if self.filter is not None:
            out = out * eval_discrete(self.filter, z)
        return out

    def response(self, freq_hz: np.ndarray, dt: float) -> np.ndarray:
        """``W(j w)`` of eq. (4.26) at ``freq_hz`` (any shape) [s], complex."""
        return self.filter_response(freq_hz, dt) * zoh_response(freq_hz, self.fast_dt(dt))

    # ---------------------------------------------------------- discrete model
    def discretize(self, plant: ModalPlant, dt: float) -> control.StateSpace:
        """Exact discrete model ``Pdm`` from ``ud`` to ``yd`` at ``dt`` (eq. 4.25), state space.

        The fast model ``G = Pc_zoh(dt/m) * Ip * Fm`` is lifted over one slow period:
        with zero insertion only the first of the ``m`` fast inputs is non-zero, so
        ``x[n+1] = A^m x[n] + A^(m-1) B ud[n]`` and ``yd[n] = C x[n] + D ud[n]``.
        """
        return self.discretize_data(plant, dt).to_control()

    def discretize_data(self, plant: ModalPlant, dt: float, method: str = "expm") -> StateSpaceData:
        """:meth:`discretize` as numpy arrays (python-control unloaded for RationalTF parts).

        Parameters
        ----------
        plant : ModalPlant
            Continuous plant with its input delay.
        dt : float
            Slow (controller) period [s].
        method : {"expm", "modal"}
            The plant's ZOH (:meth:`~servokit.models.ModalPlant.discretize_data`).

        Returns
        -------
        StateSpaceData
            The model :meth:`discretize` returns (``.to_control()`` converts).
        """
        h = self.fast_dt(dt)
        fast = series(as_state_space_data(self._chain(dt)), plant.discretize_data(h, method))
        # m is a small integer (the multirate number): a few products, not a long loop
        Am1 = np.linalg.matrix_power(fast.A, self.m - 1)
        return StateSpaceData(Am1 @ fast.A, Am1 @ fast.B, fast.C, fast.D, dt)
