"""FSC inputs for modal plants: minimum jerk (2.40)-(2.42) and frequency-shaped FSC (2.44)-(2.75).

Implements

* (2.37)-(2.42): the plant ``P(s)`` (without its input delay, as the book designs: §2.5.2)
  discretised exactly under a ZOH and augmented with the discrete integrator ``1/(z-1)``
  of Fig. 2.11, so that the optimised input ``u[k]`` is a jerk and the held plant input
  ``u_c[k]`` starts at ``u_c[0] = 0`` and returns to ``u_c[N] = 0``;
* (2.43)-(2.52), (2.58): the spectrum ``Uc(w) = 2 sin(w tau/2)/w e^{-j w tau/2} sum_k
  u_c[k] e^{-j w tau k}`` of the held input;
* (2.44), (2.59)-(2.61) and the per-mode band form (2.74)-(2.75): the frequency-shaped cost
  ``J_w = rho sum_k u[k]^2 + sum_i q_i sum_j |Uc(2 pi f_ij)|^2``, written as ``||W U||^2``
  and handed to :func:`servokit.feedforward.fsc.final_state_control` as ``Q_factor=W``;
* (2.62)-(2.72): with constraints, the same cost and final-state equality plus the
  constraints' inequality rows, solved as a QP by
  :func:`servokit.feedforward.constraints.solve_fsc_qp`;
* the search for N over a plant set (§2.4.2) is :func:`servokit.seek.choose_N`: it
  evaluates designs by simulation, a layer above this one.

Constraint objects are duck-typed: each has ``rows(model: LiftedModel) -> (G, h)`` giving
inequality rows ``G U <= h`` on the decision (jerk) vector, where ``model`` is the
:class:`~servokit.feedforward.fsc.LiftedModel` of the augmented design model (plant input
``u_c`` = ``model.plant_input(U)``, states ``model.states(U)``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite
from servokit.feedforward.fsc import final_state_control, lifted_model
from servokit.models._zoh import block_diagonal, modal_zoh
from servokit.models.modal import ModalPlant

__all__ = [
    "StepsBelowOrderError",
    "FeedforwardInput",
    "augmented_design_model",
    "band_frequencies",
    "fsc_input",
    "held_spectrum_matrix",
]


class StepsBelowOrderError(ServokitValueError):
    """The step number N is too small for the design model (below its order)."""


BandWeight = tuple[float, float, float, int]


def held_spectrum_matrix(freq_hz: np.ndarray, dt: float, N: int) -> np.ndarray:
    """Matrix E (F, N) with ``Uc(2 pi f) = E @ u_c`` for a held sequence, eqs. (2.51)-(2.52).

    ``2 sin(w dt/2)/w`` is evaluated as ``dt * sinc(f dt)`` so that ``f = 0`` gives ``dt``.

    Parameters
    ----------
    freq_hz : array_like
        Frequencies ``f`` [Hz]; flattened to F values.
    dt : float
        Hold period ``tau`` [s].
    N : int
        Number of held samples ``u_c[0..N-1]``.

    Returns
    -------
    ndarray of complex (F, N)
        ``E[i, k] = dt sinc(f_i dt) exp(-j w_i dt / 2) exp(-j w_i k dt)`` with
        ``w_i = 2 pi f_i``: the Fourier transform of the unit pulse held on
        ``[k dt, (k+1) dt)``.
    """
    f = np.asarray(freq_hz, dtype=float).reshape(-1)
    w = 2.0 * np.pi * f
    u1 = dt * np.sinc(f * dt)
    k = np.arange(N)
    return (u1 * np.exp(-0.5j * w * dt))[:, None] * np.exp(-1j * np.outer(w, k) * dt)


def band_frequencies(f_low_hz: float, f_high_hz: float, n_points: int) -> np.ndarray:
    """The ``n_points`` frequencies [Hz] of one band of (2.75), ``f_low`` to ``f_high`` inclusive.

    The book prints ``f_ij = f_li + (f_ui - f_li) j / (l_i - 1)`` with ``j = 1..l_i``, which
    would step past ``f_ui``; the spacing ``/(l_i - 1)`` shows ``j = 0..l_i-1`` is meant.

    Parameters
    ----------
    f_low_hz, f_high_hz : float
        Lower and upper band edges ``f_li``, ``f_ui`` [Hz].
    n_points : int
        Number of frequencies ``l_i`` in the band.

    Returns
    -------
    ndarray (n_points,)
        Evenly spaced frequencies [Hz] from ``f_low_hz`` to ``f_high_hz``, both included.
    """
    return np.linspace(f_low_hz, f_high_hz, n_points)


def _check_bands(band_weights: Iterable[Sequence[float]]) -> list[BandWeight]:
    bands: list[BandWeight] = []
    for i, band in enumerate(band_weights):
        try:
            f_lo, f_hi, q, n_pts = band
        except (TypeError, ValueError):
            raise ServokitTypeError(
                f"band_weights[{i}] must be a tuple (f_low_hz, f_high_hz, weight, n_points), "
                f"got {band!r}"
            ) from None
        f_lo, f_hi, q = (float(v) for v in check_finite(f"band_weights[{i}]", [f_lo, f_hi, q]))
        if isinstance(n_pts, bool) or not isinstance(n_pts, int | np.integer) or n_pts < 1:
            raise ServokitValueError(f"band_weights[{i}]: n_points must be an integer >= 1")
        if not 0.0 <= f_lo <= f_hi:
            raise ServokitValueError(
                f"band_weights[{i}]: need 0 <= f_low_hz <= f_high_hz, got {f_lo}, {f_hi}"
            )
        if q < 0:
            raise ServokitValueError(f"band_weights[{i}]: weight must be >= 0, got {q}")
        bands.append((f_lo, f_hi, q, int(n_pts)))
    return bands


@dataclass(frozen=True, eq=False)
class FeedforwardInput:
    """A held feedforward input ``u_c`` designed by (F)FSC.

    Attributes
    ----------
    u : ndarray (N,)
        Held plant input ``u_c[0..N-1]``, each applied for ``dt`` from ``t = k dt``;
        ``u_c[0] = 0`` and the input is zero from ``t = N dt`` on (``u_c[N] = 0``, eq. 2.42),
        so the trailing zero of the book is implied rather than stored.
    dt : float
        Hold (sampling) period [s].
    target : float
        Final position of the design model (plant output units, e.g. tracks).
    jerk : ndarray (N,)
        The optimised integrator input ``u[0..N-1]`` of (2.40), ``u_c[k+1] = u_c[k] + u[k]``.
    design : str
        Short description of the design (model, weights).
    """

    u: np.ndarray
    dt: float
    target: float
    jerk: np.ndarray = field(repr=False)
    design: str = ""

    @property
    def N(self) -> int:
        """Number of steps of the design."""
        return int(self.u.shape[0])

    @property
    def duration(self) -> float:
        """Time [s] at which the input returns to zero for good, ``N dt``."""
        return self.N * self.dt

    def spectrum(self, freq_hz: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Fourier transform ``Uc(2 pi f)`` of the held input, eq. (2.51); same shape as input."""
        f = check_finite("freq_hz", freq_hz)
        return (held_spectrum_matrix(f, self.dt, self.N) @ self.u).reshape(f.shape)

    def time_response(
        self, substeps: int = 10, *, n_after: int = 0
    ) -> tuple[np.ndarray, np.ndarray]:
        """The held input on a fine grid ``dt / substeps`` from 0 to ``(N + n_after) dt``.

        Returns ``(t, u)`` with ``u[i]`` the value held from ``t[i]`` to ``t[i+1]``.
        """
        if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
            raise ServokitValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        held = np.concatenate([self.u, np.zeros(n_after + 1)])
        u = np.repeat(held, substeps)[: (self.N + n_after) * substeps + 1]
        t = np.arange(u.size) * (self.dt / substeps)
        return t, u


def augmented_design_model(plant: ModalPlant, dt: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Exact ZOH of ``plant`` (delay ignored) augmented with ``1/(z-1)``, eqs. (2.38)-(2.41).

    The state is ``[x_d, u_c]`` with ``x_d`` in the modal order of
    :meth:`ModalPlant.to_statespace` (``[q_i, dq_i/dt]`` per mode). Each mode's ZOH is
    the closed form of :func:`~servokit.models._zoh.modal_zoh` (equal to
    ``scipy.linalg.expm`` of the mode's Van Loan matrix to ~1e-13 of each row, which
    ``tests/test_fsc_numpy_core.py`` checks), so that a seek design never imports
    scipy.linalg, whose import alone costs a command's start-up a fifth of a second
    (issue 23).

    Parameters
    ----------
    plant : ModalPlant
        Design model; its input delay is ignored.
    dt : float
        Sampling (hold) period ``tau`` [s].

    Returns
    -------
    A : ndarray (n + 1, n + 1)
        ``[[Ad, Bd], [0, 1]]``: the ZOH plant driven by the held input ``u_c``, which the
        integrator state accumulates.
    B : ndarray (n + 1,)
        Input column ``[0, ..., 0, 1]``: the decision input ``u[k]`` (the jerk) enters
        ``u_c[k+1] = u_c[k] + u[k]``.
    n_modal : int
        Number ``n`` of modal states (twice the number of modes); ``u_c`` is state ``n``.
    """
    Phis, Gammas = modal_zoh(*plant.arrays(), dt)
    n = 2 * Phis.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = block_diagonal(Phis)
    A[:n, n] = Gammas.reshape(n)
    A[n, n] = 1.0
    B = np.zeros(n + 1)
    B[n] = 1.0
    return A, B, n


def _final_state(plant: ModalPlant, target: float, n: int) -> np.ndarray:
    """Rest at ``y = target``: rigid-body positions share it in proportion to their residues."""
    residues = np.array([m.residue for m in plant.modes])
    rigid = np.array([m.freq_hz == 0.0 for m in plant.modes])
    xN = np.zeros(n + 1)
    if target != 0.0:
        if not rigid.any():
            raise ServokitValueError(
                f"plant {plant.name!r} has no rigid-body mode, so u_c[N] = 0 leaves it at 0; "
                "a non-zero target needs a plant with a Mode(0, 0, residue)"
            )
        share = np.where(rigid, residues, 0.0) / residues[rigid].sum()
        xN[0:n:2] = target * share
    return xN


def _band_rows(dt: float, N: int, bands: list[BandWeight]) -> np.ndarray | None:
    """Band rows ``W_b`` of the cost, eqs. (2.59)-(2.61) / (2.74), or None without bands."""
    freqs, weights = [], []
    for f_lo, f_hi, q, n_pts in bands:
        if q > 0:
            freqs.append(band_frequencies(f_lo, f_hi, n_pts))
            weights.append(np.full(n_pts, q))
    if not freqs:
        return None
    f = np.concatenate(freqs)
    E = held_spectrum_matrix(f, dt, N)
    # Uc = Omega_w U (2.46)-(2.48): u_c[k] = sum_{i<k} u[i], a strictly lower cumulative sum.
    E_u = np.cumsum(E[:, ::-1], axis=1)[:, ::-1]
    E_u = np.concatenate([E_u[:, 1:], np.zeros((f.size, 1))], axis=1)
    sq = np.sqrt(np.concatenate(weights))[:, None]
    return np.vstack([sq * E_u.real, sq * E_u.imag])


def _cost_factor(
    dt: float, N: int, bands: list[BandWeight], input_weight: float
) -> np.ndarray | None:
    """W with ``J_w = ||W U||^2``, eqs. (2.59)-(2.61) / (2.74): jerk term and band terms."""
    Wb = _band_rows(dt, N, bands)
    if Wb is None:
        return None  # a scalar multiple of I does not change the minimiser
    return np.vstack([np.sqrt(input_weight) * np.eye(N), Wb])


def fsc_input(
    plant: ModalPlant,
    dt: float,
    N: int,
    target: float,
    *,
    band_weights: Iterable[Sequence[float]] = (),
    constraints: Iterable[Any] = (),
    model: Literal["plant", "rigid-body"] = "plant",
    input_weight: float | None = None,
    qp: Literal["auto", "dense"] = "auto",
) -> FeedforwardInput:
    """Minimum-jerk FSC / frequency-shaped FFSC input for a modal plant, eqs. (2.40)-(2.75).

    Parameters
    ----------
    plant : ModalPlant
        Design model.  Its input delay is ignored, as in the book (§2.5.2): the delay only
        shifts the response and is accounted for when the input is simulated or applied.
    dt : float
        Hold period [s] (e.g. Ts = 37.879 us for the HDD benchmark).
    N : int
        Number of steps; ``u_c`` is non-zero on ``[dt, N dt)`` only.
    target : float
        Final position (plant output units).
    band_weights : iterable of (f_low_hz, f_high_hz, weight, n_points)
        Frequency shaping (2.74)-(2.75): ``weight * sum_j |Uc(2 pi f_j)|^2`` over ``n_points``
        frequencies from ``f_low_hz`` to ``f_high_hz``.  Empty gives the FSC input (2.36).
    constraints : iterable
        Objects with ``rows(model: LiftedModel) -> (G, h)`` (e.g. those of
        :mod:`servokit.feedforward.constraints`); non-empty turns the design into the QP of
        (2.64)-(2.72).
    model : {"plant", "rigid-body"}
        Design on the full plant, or on ``plant.rigid_body()`` (the book's Design 1).
    input_weight : float, optional
        Weight rho of ``sum u[k]^2``; default ``1/N`` as in (2.74).  Use 1.0 for (2.44).
    qp : {"auto", "dense"}
        Formulation of a constrained design: ``"auto"`` tries the banded sparse QP when
        :func:`~servokit.feedforward.sparse_qp.prefers_banded` expects it to be faster
        (from ``N >= 200`` steps, few band rows) and falls back to the dense QP when it
        fails; ``"dense"`` goes straight to the dense QP.  Both return the same optimum
        (to ~1e-7 relative; bench/qp.py).

    Returns
    -------
    FeedforwardInput

    Raises
    ------
    ServokitValueError
        Bad arguments, ``N`` below the order of the augmented model, or final state missed.
    """
    if not isinstance(plant, ModalPlant):
        raise ServokitTypeError(
            f"plant must be a servokit ModalPlant, got {type(plant).__name__}; "
            "see servokit.models.ModalPlant"
        )
    if model not in ("plant", "rigid-body"):
        raise ServokitValueError(f"model must be 'plant' or 'rigid-body', got {model!r}")
    if qp not in ("auto", "dense"):
        raise ServokitValueError(f"qp must be 'auto' or 'dense', got {qp!r}")
    dt = float(check_finite("dt", dt))
    if dt <= 0:
        raise ServokitValueError(f"dt must be > 0 seconds, got {dt}")
    target = float(check_finite("target", target))
    design_plant = plant.rigid_body() if model == "rigid-body" else plant
    bands = _check_bands(band_weights)
    if isinstance(N, bool) or not isinstance(N, int | np.integer):
        raise ServokitTypeError(f"N must be an integer number of steps, got {N!r}")
    N = int(N)
    if N < 1:
        raise StepsBelowOrderError(f"N must be >= 1 step, got N={N}")
    rho = 1.0 / N if input_weight is None else float(check_finite("input_weight", input_weight))
    if rho <= 0:
        raise ServokitValueError(f"input_weight must be > 0, got {rho}")

    A, B, n = augmented_design_model(design_plant, dt)
    if N < n + 1:
        raise StepsBelowOrderError(
            f"N={N} is below the order {n + 1} of the integrator-augmented model of "
            f"{design_plant.name or 'the plant'}; use N >= {n + 1}"
        )
    x0 = np.zeros(n + 1)
    xN = _final_state(design_plant, target, n)
    cons = list(constraints)
    if cons:
        Wb = _band_rows(dt, N, bands)
        jerk = _constrained(A, B, N, x0, xN, (rho, Wb), dt, n, cons, banded=qp == "auto")
    else:
        jerk = final_state_control(A, B, N, x0, xN, Q_factor=_cost_factor(dt, N, bands, rho))
    u_c = np.concatenate([[0.0], np.cumsum(jerk)[:-1]])
    desc = f"{'FFSC' if bands else 'FSC'} on {design_plant.name or 'plant'}, N={N}"
    return FeedforwardInput(u=u_c, dt=dt, target=target, jerk=jerk, design=desc)


def _constrained(
    A: np.ndarray,
    B: np.ndarray,
    N: int,
    x0: np.ndarray,
    xN: np.ndarray,
    cost: tuple[float, np.ndarray | None],
    dt: float,
    n: int,
    constraints: list[Any],
    banded: bool = True,
) -> np.ndarray:
    """Constrained FSC as the QP of (2.64)-(2.72) solved by ``solve_fsc_qp`` (the banded
    QP first if ``banded`` and it is expected to be faster); ``cost = (rho, W_b)`` gives
    ``J = rho ||U||^2 + ||W_b U||^2``."""
    from servokit.feedforward.constraints import constraint_rows, solve_fsc_qp
    from servokit.feedforward.sparse_qp import prefers_banded, sparse_constrained_fsc

    pos = np.zeros(n + 1)
    pos[0:n:2] = 1.0
    vel = np.zeros(n + 1)
    vel[1:n:2] = 1.0
    input_row = np.zeros(n + 1)
    input_row[n] = 1.0
    rho, Wb = cost
    # banded QP (issues 8, 24) when it should be faster; None: on to the dense path
    if banded and prefers_banded(N, A.shape[0], 0 if Wb is None else Wb.shape[0]):
        U = sparse_constrained_fsc(
            A, B, N, x0, xN, rho=rho, band_rows=Wb, dt=dt, position=pos, velocity=vel,
            input_row=input_row, constraints=constraints,
        )  # fmt: skip
        if U is not None:
            return U
    lm = lifted_model(A, B, N, x0, dt=dt, position=pos, velocity=vel, input_row=input_row)
    G, h, groups = constraint_rows(constraints, lm)
    P = np.eye(N) if Wb is None else Wb.T @ Wb  # rho I + W_b^T W_b, never W^T W with I in W
    if Wb is not None:
        P[np.diag_indices(N)] += rho
    Sigma = lm.x_gain[N]
    X = xN - lm.x_offset[N]
    # Equilibrated equality rows (same solution set) keep the QP solver's tolerances meaningful.
    scale = np.linalg.norm(Sigma, axis=1)
    scale[scale == 0] = 1.0
    U = solve_fsc_qp(P, np.zeros(N), Sigma / scale[:, None], X / scale, G, h, groups=groups)
    return np.asarray(U, dtype=float)
