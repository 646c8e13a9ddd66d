"""Modal plants with input delay: the book's universal model.

Implements

    P(s) = K * sum_i A_i / (s^2 + 2 zeta_i omega_i s + omega_i^2) * exp(-s Td)

as written in eq. (1.1)/(2.73) (HDD benchmark), (4.64)-(4.65) (sampled-data HDD),
(5.1) and (5.12) (VCM and PZT active suspension) and (6.7) (SVM head plant).  A mode
at ``freq_hz = 0`` with zero damping is the rigid-body mode ``A_i / s^2``.

:class:`ModalPlant` evaluates the frequency response exactly (delay included),
returns the continuous real modal state-space model (python-control, no delay) and
discretises it exactly under a zero-order hold, including a delay that is not a
multiple of the sampling period (extra delay states, see :func:`delayed_zoh`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.models._zoh import block_diagonal, delayed_zoh, modal_delayed_zoh
from servokit.models.rational import StateSpaceData

if TYPE_CHECKING:
    import control

__all__ = ["MAX_DELAY_S", "Mode", "ModalPlant", "modal_matrices", "without_delay"]

#: Largest input delay accepted [s].  Servo delays are micro- to milliseconds; a delay
#: of seconds is almost always a unit slip (``delay=10`` meant 10 us) and would make the
#: exact discretisation allocate ``delay / dt`` delay states.
MAX_DELAY_S = 1.0


def _finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ServokitTypeError(f"{name} must be a real number, got {value!r}") from None
    if not np.isfinite(v):
        raise ServokitValueError(f"{name} must be finite, got {value!r}; pass a finite number")
    return v


@dataclass(frozen=True)
class Mode:
    """One mode ``residue / (s^2 + 2 damping w s + w^2)`` with ``w = 2 pi freq_hz``.

    Parameters
    ----------
    freq_hz : float
        Natural frequency [Hz]; 0 for the rigid-body mode.
    damping : float
        Damping ratio (>= 0).
    residue : float
        Modal residue (dimensionless; the plant gain multiplies it).
    """

    freq_hz: float
    damping: float
    residue: float

    def __post_init__(self) -> None:
        f = _finite("Mode.freq_hz", self.freq_hz)
        z = _finite("Mode.damping", self.damping)
        r = _finite("Mode.residue", self.residue)
        if f < 0:
            raise ServokitValueError(
                f"Mode.freq_hz must be >= 0 (got {f}); use 0 for the rigid body"
            )
        if z < 0:
            raise ServokitValueError(
                f"Mode.damping must be >= 0 (got {z}); a negative damping ratio is an unstable mode"
            )
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping", z)
        object.__setattr__(self, "residue", r)

    @property
    def omega(self) -> float:
        """Natural frequency [rad/s]."""
        return 2.0 * np.pi * self.freq_hz


@dataclass(frozen=True)
class ModalPlant:
    """Sum of second-order modes times a gain, with an input delay.

    Parameters
    ----------
    gain : float
        Plant gain K (e.g. Kp = 3.93e9 track/A/s^2 for the HDD benchmark).
    modes : sequence of Mode
        At least one mode.
    delay : float
        Input (dead-time) delay Td [s], >= 0.
    name : str
        Human-readable name.
    source : str
        Where the parameters come from (book table / section), or "illustrative".
    """

    gain: float
    modes: tuple[Mode, ...]
    delay: float = 0.0
    name: str = ""
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        g = _finite("gain", self.gain)
        if g == 0:
            raise ServokitValueError("gain must be non-zero; pass the plant gain K")
        d = _finite("delay", self.delay)
        if d < 0:
            raise ServokitValueError(f"delay must be >= 0 seconds (got {d})")
        if d > MAX_DELAY_S:
            raise ServokitValueError(
                f"delay must be <= {MAX_DELAY_S:g} s (got {d:g}); the delay is in seconds "
                f"(did you mean {d:g}e-6 for {d:g} us?)"
            )
        if isinstance(self.modes, Mode) or not isinstance(self.modes, Iterable):
            raise ServokitTypeError("modes must be a sequence of Mode(freq_hz, damping, residue)")
        modes = tuple(self.modes)
        if not modes:
            raise ServokitValueError(
                "modes is empty; give at least one Mode (the rigid body is Mode(0, 0, 1))"
            )
        for i, m in enumerate(modes):
            if not isinstance(m, Mode):
                raise ServokitTypeError(f"modes[{i}] must be a Mode, got {type(m).__name__}")
        object.__setattr__(self, "gain", g)
        object.__setattr__(self, "delay", d)
        object.__setattr__(self, "modes", modes)

    # ----------------------------------------------------------------- views
    @property
    def order(self) -> int:
        """Number of continuous states (two per mode)."""
        return 2 * len(self.modes)

    def replace(self, **changes: object) -> ModalPlant:
        """Return a copy with fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def resonances_hz(self) -> list[float]:
        """Frequencies of the resonant (non rigid-body) modes [Hz], in mode order.

        Returns
        -------
        list of float
            ``freq_hz`` of every mode with ``freq_hz > 0``.
        """
        return [m.freq_hz for m in self.modes if m.freq_hz > 0]

    def rigid_body(self) -> ModalPlant:
        """The plant keeping only its rigid-body (freq 0) modes, as used by the book's Design 1."""
        rigid = tuple(m for m in self.modes if m.freq_hz == 0.0)
        if not rigid:
            raise ServokitValueError(f"plant {self.name!r} has no rigid-body mode (freq_hz == 0)")
        return self.replace(modes=rigid, name=f"{self.name} (rigid body)".strip())

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mode frequencies [rad/s], damping ratios and gain*residues as arrays."""
        w = np.array([m.omega for m in self.modes])
        z = np.array([m.damping for m in self.modes])
        r = self.gain * np.array([m.residue for m in self.modes])
        return w, z, r

    # ------------------------------------------------------------- responses
    def freqresp(self, freq_hz: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Exact frequency response P(j 2 pi f), delay included.

        Parameters
        ----------
        freq_hz : array_like
            Frequencies [Hz] (any shape).

        Returns
        -------
        ndarray of complex, same shape as ``freq_hz``.
        """
        f = np.asarray(freq_hz, dtype=float)
        if not np.all(np.isfinite(f)):
            raise ServokitValueError("freq_hz must be finite")
        s = 2j * np.pi * f[..., None]
        w, z, r = self.arrays()
        den = s * s + 2 * z * w * s + w * w
        hit = np.any(den == 0, axis=-1)
        if np.any(hit):
            bad = f[hit].ravel()[0]
            raise ServokitValueError(
                f"freq_hz = {bad:g} Hz is a pole of {self.name or 'the plant'} (an undamped mode "
                "or the rigid body at 0 Hz); evaluate the response away from it"
            )
        modal = np.sum(r / den, axis=-1)
        return modal * np.exp(-s[..., 0] * self.delay)

    def to_statespace(
        self, delay: Literal["none", "pade"] = "none", pade_order: int = 3
    ) -> control.StateSpace:
        """Continuous real modal state space, without or with a Padé approximation of the delay.

        Parameters
        ----------
        delay : {"none", "pade"}
            ``"none"`` drops the input delay (the modal part only, exact); ``"pade"``
            puts a ``pade_order`` Padé approximant of ``exp(-s Td)`` in front of it
            (:func:`control.pade`), so that ``control.feedback`` and products with
            controllers see the delay's phase lag up to roughly ``pade_order / (pi Td)`` Hz.
            :meth:`freqresp` and :meth:`to_frd` are exact; use them to check.
        pade_order : int
            Order of the Padé approximant (``delay="pade"`` only), 1..10.

        Returns
        -------
        control.StateSpace
            State order: for each mode ``[q_i, dq_i/dt]`` with
            ``q_i'' + 2 zeta_i w_i q_i' + w_i^2 q_i = K A_i u`` and ``y = sum_i q_i``;
            with ``delay="pade"`` the Padé states come last.
        """
        import control

        A, B, C = modal_matrices(*self.arrays())
        modal = control.ss(A, B, C, np.zeros((1, 1)))
        if delay == "none" or (delay == "pade" and self.delay == 0.0):
            return modal
        if delay != "pade":
            raise ServokitValueError(f"delay must be 'none' or 'pade' (got {delay!r})")
        if isinstance(pade_order, bool) or not isinstance(pade_order, int | np.integer):
            raise ServokitTypeError(f"pade_order must be an integer 1..10, got {pade_order!r}")
        if not 1 <= pade_order <= 10:
            raise ServokitValueError(f"pade_order must be 1..10 (got {pade_order})")
        # Pade of a unit delay, then s -> s Td: the direct approximant for Td = 10 us has
        # coefficients up to 1e35 and a singular companion realisation
        unit = control.ss(control.tf(*control.pade(1.0, int(pade_order))))
        T = self.delay
        pade = control.ss(unit.A / T, unit.B / T, unit.C, unit.D)
        return control.series(pade, modal)

    def to_frd(self, freq_hz: Sequence[float] | np.ndarray) -> control.FrequencyResponseData:
        """Exact frequency response data (delay included) for python-control.

        ``control.bode_plot(plant.to_frd(f))`` plots it; frequencies are given in Hz and
        stored in rad/s as python-control expects.
        """
        import control

        f = np.asarray(freq_hz, dtype=float).ravel()
        if f.size == 0 or np.any(f <= 0):
            raise ServokitValueError("freq_hz must be a non-empty array of frequencies > 0 Hz")
        return control.frd(self.freqresp(f), 2.0 * np.pi * f, name=self.name or "plant")

    def to_discrete(self, dt: float) -> control.StateSpace:
        """Exact ZOH discretisation with the input delay (the same as :meth:`discretize`)."""
        return self.discretize(dt)

    def discretize(self, dt: float) -> control.StateSpace:
        """Exact ZOH discretisation with the input delay, as a python-control ``StateSpace``.

        With ``delay = d*dt + frac`` the model is augmented with the past inputs it needs:
        ``d + 1`` extra states ``u[k-1], ..., u[k-d-1]`` when ``frac > 0``, ``d`` when the
        delay is a whole number of samples (see :func:`servokit.models._zoh.delayed_zoh`).
        The modal states come first, the delay states last.
        """
        return self.discretize_data(dt).to_control()

    def discretize_data(self, dt: float, method: str = "expm") -> StateSpaceData:
        """:meth:`discretize` as numpy arrays, python-control left unloaded (start-up).

        Parameters
        ----------
        dt : float
            Sampling period [s], > 0.
        method : {"expm", "modal"}
            ``"expm"``: ``scipy.linalg.expm`` of the augmented matrix (what
            :meth:`discretize` returns, bit for bit); ``"modal"``: each mode's ZOH in
            closed form (:func:`~servokit.models._zoh.modal_delayed_zoh`, the same states
            within ~1e-13 of the norm) without importing scipy.linalg, whose import alone
            costs a command's start-up a fifth of a second (issue 23).

        Returns
        -------
        StateSpaceData
            The exact ZOH state space with the delay line (``.to_control()`` converts).
        """
        dt = _finite("dt", dt)
        if dt <= 0:
            raise ServokitValueError(f"dt must be > 0 seconds (got {dt})")
        w, z, r = self.arrays()
        A, B, C = modal_matrices(w, z, r)
        if method == "expm":
            Phi, Gnew, Gold, d = delayed_zoh(A, B, dt, self.delay)
            return _with_delay_line(Phi, Gnew, Gold, d, C, dt)
        if method != "modal":
            raise ServokitValueError(f"method must be 'expm' or 'modal' (got {method!r})")
        Phis, Gns, Gos, d = modal_delayed_zoh(w, z, r, dt, self.delay)
        n = 2 * w.size
        Phi = block_diagonal(Phis)  # one 2x2 block per mode
        return _with_delay_line(Phi, Gns.reshape(n, 1), Gos.reshape(n, 1), d, C, dt)

    def __str__(self) -> str:
        return self.name or f"ModalPlant({len(self.modes)} modes)"


def _with_delay_line(
    Phi: np.ndarray, Gnew: np.ndarray, Gold: np.ndarray, d: int, C: np.ndarray, dt: float
) -> StateSpaceData:
    """The delayed ZOH model ``x+ = Phi x + Gnew u[k-d] + Gold u[k-d-1]`` with the past
    inputs it needs as extra states (``d + 1`` with a fractional delay, else ``d``)."""
    has_old = bool(np.any(Gold != 0.0))
    n_del = d + 1 if has_old else d
    n = Phi.shape[0]
    if n_del == 0:
        return StateSpaceData(Phi, Gnew, C, np.zeros((1, 1)), dt)
    N = n + n_del
    Ad = np.zeros((N, N))
    Bd = np.zeros((N, 1))
    Ad[:n, :n] = Phi
    # delay line: state n + j holds u[k-1-j]
    Bd[n, 0] = 1.0
    for j in range(1, n_del):
        Ad[n + j, n + j - 1] = 1.0
    # u[k-d] enters with Gnew, u[k-d-1] with Gold
    if d == 0:
        Bd[:n] = Gnew
    else:
        Ad[:n, n + d - 1 : n + d] = Gnew
    if has_old:
        Ad[:n, n + d : n + d + 1] = Gold
    Cd = np.zeros((1, N))
    Cd[:, :n] = C
    return StateSpaceData(Ad, Bd, Cd, np.zeros((1, 1)), dt)


def modal_matrices(
    w: np.ndarray, z: np.ndarray, r: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Block-diagonal real modal (A, B, C) for frequencies ``w`` [rad/s], dampings, gains ``r``.

    Parameters
    ----------
    w : ndarray (n,)
        Natural frequencies ``omega_i`` [rad/s]; 0 for a rigid-body mode.
    z : ndarray (n,)
        Damping ratios ``zeta_i``.
    r : ndarray (n,)
        Input gains ``K A_i`` (plant gain times residue), as :meth:`ModalPlant.arrays`
        returns them.

    Returns
    -------
    A : ndarray (2n, 2n)
        Block diagonal, ``[[0, 1], [-w_i^2, -2 zeta_i w_i]]`` per mode.
    B : ndarray (2n, 1)
        ``r_i`` in the velocity row of each mode.
    C : ndarray (1, 2n)
        1 in the position row of each mode: ``y = sum_i q_i``.
    """
    n = len(w)
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros((2 * n, 1))
    C = np.zeros((1, 2 * n))
    for i in range(n):
        A[2 * i, 2 * i + 1] = 1.0
        A[2 * i + 1, 2 * i] = -(w[i] ** 2)
        A[2 * i + 1, 2 * i + 1] = -2.0 * z[i] * w[i]
        B[2 * i + 1, 0] = r[i]
        C[0, 2 * i] = 1.0
    return A, B, C


def without_delay(plants: ModalPlant | Sequence[ModalPlant]) -> list[ModalPlant]:
    """Copies of the plants with the input delay removed (the book's §2.4 convention).

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Plants to copy.

    Returns
    -------
    list of ModalPlant
        One copy per plant, ``delay = 0``, everything else unchanged.
    """
    if isinstance(plants, ModalPlant):
        plants = [plants]
    return [p.replace(delay=0.0) for p in plants]
