"""Problem set-up of loop shaping from measured FRFs: data checks, grids, controller structures.

A controller ``K = x(z^{-1}) / y(z^{-1})`` is linear in its parameters: the numerator
coefficients ``a`` and the free coefficients ``b`` of a monic denominator factor,

    ``x = Σ_{m=0}^{n_x} a_m z^{-m}``,   ``y = d(z^{-1}) (1 + Σ_{m=1}^{n_b} b_m z^{-m})``,

where ``d`` is a fixed monic factor (integrator, fixed notch and low-pass poles). ``y`` is
monic (``y(0) = 1``), so the closed-loop characteristic polynomial always has full degree,
the fact the stability certificate of :mod:`~servokit.feedback.loopshape_solve` rests on.

* :func:`pid_notch_structure`: the benchmark's form, PID + notches + low-pass with every
  denominator fixed (``n_b = 0``): the sensitivity constraints become linear.
* :func:`fixed_order_structure`: a general order-``N`` controller with an integrator and
  ``N - 1`` free denominator coefficients.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_finite, check_positive

__all__ = [
    "bank_frfs",
    "Structure",
    "pid_notch_structure",
    "fixed_order_structure",
    "check_frf_set",
    "packed_grid",
    "model_frfs",
    "modal_banks",
    "controller_polys",
]


@dataclass(frozen=True)
class Structure:
    """A linearly parameterised controller ``x / (d · (1 + Σ b_m z^{-m}))`` (module doc).

    Parameters
    ----------
    den_fixed : ndarray
        Fixed monic denominator factor ``d`` in powers of ``z^{-1}`` (``d[0] = 1``).
    n_num : int
        Degree of the numerator ``x`` in ``z^{-1}``.
    n_den_free : int
        Number of free denominator coefficients ``b``.
    n_integrators : int
        Roots of ``d`` at ``z = 1``.
    name : str
        Label for tables and files.
    """

    den_fixed: np.ndarray
    n_num: int
    n_den_free: int
    n_integrators: int
    name: str

    @property
    def order(self) -> int:
        """Number of controller states (degree of the denominator)."""
        return len(self.den_fixed) - 1 + self.n_den_free

    @property
    def n_params(self) -> int:
        """Number of free parameters ``len(a) + len(b)``."""
        return self.n_num + 1 + self.n_den_free

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and full denominator coefficients (powers of ``z^{-1}``) of ``theta``.

        Parameters
        ----------
        theta : ndarray
            ``[a, b]``, length :attr:`n_params`.

        Returns
        -------
        tuple of ndarray
            ``x`` and ``y`` coefficients in ascending powers of ``z^{-1}``.
        """
        a = theta[: self.n_num + 1]
        y = np.convolve(self.den_fixed, np.concatenate([[1.0], theta[self.n_num + 1 :]]))
        return a, y

    def transfer_function(self, theta: np.ndarray, dt: float) -> control.TransferFunction:
        """The controller as a discrete python-control transfer function.

        Parameters
        ----------
        theta : ndarray
            Parameters ``[a, b]``.
        dt : float
            Sampling period [s].

        Returns
        -------
        control.TransferFunction
            ``K(z)`` with numerator and denominator padded to the same degree in ``z``.
        """
        a, y = self.split(theta)
        n = max(len(a), len(y))
        num = np.concatenate([a, np.zeros(n - len(a))])
        den = np.concatenate([y, np.zeros(n - len(y))])
        return control.tf(num, den, dt)


def _tustin_section(num: list[float], den: list[float], dt: float, f_hz: float) -> np.ndarray:
    """Denominator of a Tustin-prewarped continuous section, monic in ``z^{-1}``."""
    d = control.sample_system(
        control.tf(num, den), dt, method="tustin", prewarp_frequency=2 * np.pi * f_hz
    )
    c = np.asarray(d.den[0][0], dtype=float)
    return c / c[0]


def pid_notch_structure(
    dt: float,
    *,
    notches: tuple[tuple[float, float], ...],
    lowpass_hz: tuple[float, ...] = (),
    extra_num: int = 0,
) -> Structure:
    """PID + notches + low-pass with fixed denominators (the IEEJ benchmark's form).

    The denominator is ``(1 - z^{-1})`` (integral action) times one first-order section per
    low-pass corner and one second-order section per notch, each sampled by Tustin prewarped
    at its own frequency (as :func:`servokit.models.benchmark_controller`). The numerator
    has the full degree, so its zeros place the PID zeros and the notch zeros freely.

    Parameters
    ----------
    dt : float
        Sampling period [s].
    notches : tuple of (freq_hz, damping)
        Notch pole frequencies [Hz] and pole damping ratios in ``(0, 1]``.
    lowpass_hz : tuple of float
        Corner frequencies of first-order low-pass / lead poles [Hz].
    extra_num : int
        Extra numerator degree beyond the denominator's (0 keeps the controller proper
        with direct feed-through; must be 0).

    Returns
    -------
    Structure
        ``n_den_free = 0``; order ``1 + len(lowpass_hz) + 2 len(notches)``.
    """
    h = check_positive("dt", dt, "s")
    if extra_num != 0:
        raise ServokitValueError("extra_num must be 0 (an improper controller is not realisable)")
    d = np.array([1.0, -1.0])
    nyq = 0.5 / h
    for f in lowpass_hz:
        f = check_positive("lowpass_hz", f, "Hz")
        if f >= nyq:
            raise ServokitValueError(f"lowpass_hz {f:g} must be below Nyquist {nyq:g} Hz")
        w = 2 * np.pi * f
        d = np.convolve(d, _tustin_section([1.0], [1 / w, 1.0], h, f))
    for f, zeta in notches:
        f = check_positive("notch frequency", f, "Hz")
        zeta = check_positive("notch damping", zeta)
        if zeta > 1:  # (s^2 + 2 zeta w s + w^2) then has two real roots: no resonant pair
            raise ServokitValueError(
                f"notch damping {zeta:g} is above 1: two real poles, not a notch (the damping "
                "is a ratio, 20 % is 0.2; real poles are lowpass_hz corners)"
            )
        if f >= nyq:
            raise ServokitValueError(f"notch frequency {f:g} must be below Nyquist {nyq:g} Hz")
        w = 2 * np.pi * f
        d = np.convolve(d, _tustin_section([1.0], [1.0, 2 * zeta * w, w * w], h, f))
    order = len(d) - 1
    return Structure(d, order, 0, 1, f"pid-notch ({len(notches)} notches, {order} states)")


def fixed_order_structure(order: int) -> Structure:
    """General order-``N`` controller: integrator times a free monic factor of degree N - 1.

    Parameters
    ----------
    order : int
        Number of controller states ``N`` (1..40).

    Returns
    -------
    Structure
        Numerator of degree ``N``, ``N - 1`` free denominator coefficients.
    """
    n = check_count("order", order, lo=1, hi=40)
    return Structure(np.array([1.0, -1.0]), n, n - 1, 1, f"order {n}")


def controller_polys(ctrl: control.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of a discrete SISO controller in powers of ``z^{-1}``.

    Parameters
    ----------
    ctrl : control.TransferFunction
        Proper discrete controller.

    Returns
    -------
    tuple of ndarray
        ``x`` and ``y`` with ``y[0] = 1`` (same length).

    Raises
    ------
    ServokitValueError
        If the controller is improper or continuous.
    """
    if not ctrl.dt:
        raise ServokitValueError("initial controller must be discrete (give its dt)")
    num = np.trim_zeros(np.asarray(ctrl.num[0][0], dtype=float), "f")
    den = np.trim_zeros(np.asarray(ctrl.den[0][0], dtype=float), "f")
    if len(num) > len(den):
        raise ServokitValueError("initial controller must be proper (deg num <= deg den)")
    num = np.concatenate([np.zeros(len(den) - len(num)), num])
    return num / den[0], den / den[0]


def check_frf_set(
    freq_hz: object, responses: object, dt: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate a set of FRFs on one grid.

    Parameters
    ----------
    freq_hz : array_like
        Strictly increasing positive grid [Hz], at most Nyquist ``0.5/dt``.
    responses : array_like
        Complex FRFs, shape ``(M, n)`` or ``(n,)`` for one plant.
    dt : float
        Sampling period [s].

    Returns
    -------
    tuple
        ``freq_hz`` (float array), ``responses`` (complex, 2-D) and ``dt``.
    """
    h = check_positive("dt", dt, "s")
    f = check_finite("freq_hz", freq_hz).ravel()
    if f.size < 16:
        raise ServokitValueError(f"freq_hz needs at least 16 points (got {f.size})")
    if f[0] <= 0 or np.any(np.diff(f) <= 0):
        raise ServokitValueError("freq_hz must be positive and strictly increasing")
    if f[-1] > 0.5 / h * (1 + 1e-9):
        raise ServokitValueError(
            f"freq_hz reaches {f[-1]:g} Hz, above the Nyquist frequency {0.5 / h:g} Hz of dt"
        )
    r = np.atleast_2d(np.asarray(responses, dtype=complex))
    if r.shape[1] != f.size:
        raise ServokitValueError(
            f"responses have {r.shape[1]} points per plant; freq_hz has {f.size}"
        )
    if not np.all(np.isfinite(r)) or np.any(r == 0):
        raise ServokitValueError("responses must be finite and non-zero at every frequency")
    return f, r, h


def packed_grid(
    dt: float, resonances: list[tuple[float, float]], *, n_freq: int = 3000, fmin: float = 10.0
) -> np.ndarray:
    """Log grid up to Nyquist with points packed around lightly damped resonances.

    Half the points are logarithmic from ``fmin`` to Nyquist; the rest are shared out over
    the resonances, ``f_r (1 + ζ tan u)`` with ``u`` uniform in ``(-1.45, 1.45)``, i.e. dense
    within the half-power band ``±ζ f_r`` and reaching ``±8 ζ f_r``.

    Parameters
    ----------
    dt : float
        Sampling period [s]; the grid ends at ``0.5/dt`` exactly.
    resonances : list of (freq_hz, damping)
        Resonances to pack around (e.g. discrete poles of models).
    n_freq : int
        Total number of points.
    fmin : float
        Lowest frequency [Hz].

    Returns
    -------
    ndarray
        Strictly increasing grid of ``n_freq`` points.
    """
    nyq = 0.5 / check_positive("dt", dt, "s")
    n = check_count("n_freq", n_freq, lo=64)
    res = [(f, z) for f, z in resonances if fmin < f < nyq and z < 0.2]
    n_res = (n // 2) // max(len(res), 1) if res else 0
    u = np.linspace(-1.45, 1.45, n_res)
    parts = [f * (1 + max(z, 1e-6) * np.tan(u)) for f, z in res]
    packed = np.concatenate(parts) if parts else np.empty(0)
    packed = packed[(packed > fmin) & (packed < nyq)]
    grid = np.unique(np.concatenate([np.geomspace(fmin, nyq, n - packed.size), packed]))
    while grid.size < n:  # duplicates removed: top up with log points between the widest gaps
        k = np.argmax(np.diff(np.log(grid)))
        grid = np.insert(grid, k + 1, np.sqrt(grid[k] * grid[k + 1]))
    return grid


def modal_banks(plants: list, dt: float):
    """Exact ZOH models of modal plants at ``dt``, stacked per input delay.

    Parameters
    ----------
    plants : list of ModalPlant
        Models.
    dt : float
        Sampling period [s].

    Yields
    ------
    tuple of (ndarray, PlantBank)
        Indices into ``plants`` and the :class:`~servokit.simulate._bank.PlantBank` of those
        plants (closed-form 2x2 modal blocks, ``modal_delayed_zoh``, equal to the ``expm``
        path to 1e-13; one batch instead of three ``expm`` per plant).
    """
    from servokit.simulate._bank import PlantBank

    groups: dict[float, list[int]] = {}
    for i, p in enumerate(plants):
        groups.setdefault(float(p.delay), []).append(i)
    for idx in groups.values():
        yield np.array(idx), PlantBank.build([plants[i] for i in idx], dt)


def model_frfs(
    plants: list, dt: float, freq_hz: np.ndarray, *, method: str = "solve"
) -> np.ndarray:
    """Discrete FRFs ``P_d(e^{jωT})`` of modal plants under an exact ZOH, delay included.

    ``method="solve"`` (the reference) discretises each plant by ``expm`` and solves
    ``C (zI - Φ)^{-1} (Γ_new z^{-d} + Γ_old z^{-d-1})`` densely at every frequency.
    ``method="blocks"`` sums the 2x2 modal blocks of the closed-form ZOH
    (:func:`modal_banks`) instead, each ``[1, 0] (zI - Φ_i)^{-1}`` being its first adjugate
    row ``[z - Φ_i[1,1], Φ_i[0,1]]`` over ``det(zI - Φ_i)``: equal to the reference to
    ~1e-12 relative and 10x cheaper, for evaluating many plants.  A design keeps the
    reference: the loop-shaping iteration turns a 1e-13 change of its data into a 1e-6
    change of its result (a different but equally valid local optimum).

    Parameters
    ----------
    plants : list of ModalPlant
        Models (e.g. :func:`servokit.models.hdd_benchmark_variants`).
    dt : float
        Sampling period [s].
    freq_hz : ndarray
        Grid [Hz].
    method : {"solve", "blocks"}
        Dense solve per frequency, or closed-form modal blocks.

    Returns
    -------
    ndarray
        Shape ``(len(plants), len(freq_hz))``.
    """
    z = np.exp(2j * np.pi * np.asarray(freq_hz, dtype=float) * dt)
    if method == "blocks":
        return _block_frfs(plants, dt, z)
    if method != "solve":
        raise ServokitValueError(f"method must be 'solve' or 'blocks', got {method!r}")
    from servokit.models._zoh import delayed_zoh
    from servokit.models.modal import modal_matrices

    out = np.empty((len(plants), z.size), dtype=complex)
    for i, p in enumerate(plants):
        A, B, C = modal_matrices(*p.arrays())
        Phi, g_new, g_old, d = delayed_zoh(A, B, dt, p.delay)
        # P_d(z) = C (zI - Φ)^{-1} (Γ_new z^{-d} + Γ_old z^{-d-1}): one batched solve
        M = z[:, None, None] * np.eye(Phi.shape[0])[None] - Phi[None]
        rhs = g_new[None] * z[:, None, None] ** -d + g_old[None] * z[:, None, None] ** (-d - 1)
        out[i] = (C[None] @ np.linalg.solve(M, rhs))[:, 0, 0]
    return out


def _block_frfs(plants: list, dt: float, z: np.ndarray) -> np.ndarray:
    """``model_frfs(..., method="blocks")`` at ``z = e^{jωT}``.

    Laid out mode-major, ``(modes, plants, frequencies)``, with the real coefficients
    cast to complex once (the cast numpy makes for a real-complex operation, done on
    the small array instead of inside every broadcast pass): contiguous complex passes,
    the same operations on the same operands as the plant-major form, and the sum over
    the modes in numpy's own order (:func:`_mode_sum`), so the same numbers bit for bit
    at 60 % of the CPU (issue 24).
    """
    return bank_frfs(modal_banks(plants, dt), len(plants), z)


def bank_frfs(banks: Iterable[tuple[np.ndarray, Any]], n_plants: int, z: np.ndarray) -> np.ndarray:
    """``model_frfs(..., method="blocks")`` of plants already in plant banks, at ``z``.

    For plants held as modal arrays (e.g. Monte-Carlo draws by
    :func:`~servokit.models.variation_arrays.modal_arrays_from_draws` and
    :meth:`PlantBank.from_arrays <servokit.simulate._bank.PlantBank.from_arrays>`): no
    ``ModalPlant`` objects, and one bank serves the FRFs and :func:`certify_banks
    <servokit.feedback.loopshape_iterate.certify_banks>` (issue 24).

    Parameters
    ----------
    banks : iterable of (ndarray, PlantBank)
        Indices into the output rows and the bank of those plants at the sampling period,
        as :func:`modal_banks` yields them.
    n_plants : int
        Number of output rows (every index below it).
    z : ndarray
        Points ``e^{jωT}`` of the unit circle.

    Returns
    -------
    ndarray
        Shape ``(n_plants, len(z))``.
    """
    out = np.empty((n_plants, z.size), dtype=complex)
    zr = z[None, None, :]
    for idx, bank in banks:
        delay_factor = z ** (-bank.dd)
        # plants in chunks: (modes, plants, frequencies) complex arrays of ~1 MB, which stay
        # in cache between the elementwise passes
        step = max(1, 2**16 // (z.size * bank.Phi.shape[1]))
        for lo in range(0, idx.size, step):
            Phi, gn, go = (m[lo : lo + step] for m in (bank.Phi, bank.Gnew, bank.Gold))
            a, b, e = (
                _modes_first(Phi[..., 0, 0]),
                _modes_first(Phi[..., 0, 1]),
                _modes_first(Phi[..., 1, 1]),
            )
            ze = zr - e
            det = (zr - a) * ze - _modes_first(Phi[..., 0, 1] * Phi[..., 1, 0])
            num = ze * (_modes_first(gn[..., 0]) + _modes_first(go[..., 0]) / zr) + b * (
                _modes_first(gn[..., 1]) + _modes_first(go[..., 1]) / zr
            )
            out[idx[lo : lo + step]] = _mode_sum(list(num / det)) * delay_factor
    return out


def _modes_first(x: np.ndarray) -> np.ndarray:
    """Real ``(plants, modes)`` coefficients as complex ``(modes, plants, 1)``."""
    return np.ascontiguousarray(x.T, dtype=complex)[:, :, None]


def _mode_sum(parts: list[np.ndarray]) -> np.ndarray:
    """``np.stack(parts, -1).sum(-1)`` in numpy's association for complex sums.

    numpy sums a contiguous last axis pairwise: under 4 terms one after another, up to
    64 terms in four running sums ``r_j += x[4i + j]`` combined as ``(r0 + r1) + (r2 +
    r3)`` and the remainder added in order, above that the two halves (split at a
    multiple of 4 terms) recursively.  Adding whole arrays in that order gives the same
    numbers without the slow reduction over a short strided axis.

    Parameters
    ----------
    parts : list of ndarray
        The terms, equal shapes.

    Returns
    -------
    ndarray
        Their sum.
    """
    m = len(parts)
    if m > 64:
        h = (m - m % 8) // 2
        return _mode_sum(parts[:h]) + _mode_sum(parts[h:])
    if m < 4:
        acc = parts[0]
        for p in parts[1:]:
            acc = acc + p
        return acc
    r = list(parts[:4])
    i = 4
    while i < m - m % 4:
        for j in range(4):
            r[j] = r[j] + parts[i + j]
        i += 4
    acc = (r[0] + r[1]) + (r[2] + r[3])
    for p in parts[i:]:
        acc = acc + p
    return acc


def model_resonances(plants: list, dt: float) -> list[tuple[float, float]]:
    """Frequencies [Hz] and damping ratios of the discrete poles of modal plants.

    Parameters
    ----------
    plants : list of ModalPlant
        Models.
    dt : float
        Sampling period [s].

    Returns
    -------
    list of (freq_hz, damping)
        One entry per complex pole with positive frequency (aliases included).
    """
    out = []
    for p in plants:
        lam = np.linalg.eigvals(np.asarray(p.discretize(dt).A))
        lam = lam[(lam.imag > 1e-9) & (np.abs(lam) > 1e-9)]
        s = np.log(lam) / dt
        out += [(abs(v.imag) / (2 * np.pi), -v.real / abs(v)) for v in s]
    return out
