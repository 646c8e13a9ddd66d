"""Track-following PES simulation and evaluation as in the HDD Benchmark Problem.

Loop (one PES sample ``Ts``): the plant (modal, with delay) is discretised exactly at the
plant-input period ``Tu = Ts / r`` (``r = force_rate``) and lifted to ``Ts``:
``x[k+1] = A^r x[k] + sum_i A^(r-1-i) B (u[k] + w_i[k])``, where ``u`` is the controller
output held over ``Ts`` and ``w_i`` the force-noise samples; ``y = C x``.  The head sits at
``h = y + flutter + rro`` and the measured position error is ``PES = -(h + n)`` (target
track 0, ``n`` sensor noise); ``u = C(z) PES``.

Evaluation (benchmark ``PESEval``): RPE is the PES averaged sector by sector over the
revolutions; NRPE the rest; ``NRPE 3 sigma`` is reported in % of the track pitch; the
spectrum is a Welch PSD (:func:`welch_psd`, scipy.signal's in numpy).

The run is numpy only (issue 23, a command's start-up): the loop as arrays
(:func:`pes_closed_loop_data`), simulated in blocks of samples
(:func:`~servokit.simulate._scan.forced_outputs`); python-control's
``forced_response`` of :func:`pes_closed_loop` gives the same outputs to ~1e-13.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_memory
from servokit.models.disturbances import DisturbanceRecord
from servokit.models.modal import ModalPlant
from servokit.models.rational import StateSpaceData, as_state_space_data
from servokit.simulate._scan import forced_outputs

__all__ = [
    "PesResult",
    "lifted_plant",
    "track_following_pes",
    "pes_closed_loop",
    "pes_closed_loop_data",
    "welch_psd",
]


@dataclass(frozen=True)
class PesResult:
    """PES of a track-following run (transient revolutions removed).

    Attributes
    ----------
    pes : ndarray (n,)
        Measured position error [track].
    u : ndarray (n,)
        Controller output [A].
    dt : float
        PES sampling period [s].
    samples_per_rev : int
        Servo sectors per revolution.
    """

    pes: np.ndarray
    u: np.ndarray
    dt: float
    samples_per_rev: int

    @property
    def rpe(self) -> np.ndarray:
        """Repeatable position error, one value per sector [track]."""
        return self.pes.reshape(-1, self.samples_per_rev).mean(axis=0)

    @property
    def nrpe(self) -> np.ndarray:
        """Non-repeatable position error [track]."""
        return (self.pes.reshape(-1, self.samples_per_rev) - self.rpe).ravel()

    @property
    def nrpe_3sigma_percent(self) -> float:
        """3 sigma of the NRPE in % of the track pitch."""
        return float(300.0 * np.std(self.nrpe))

    @property
    def pes_3sigma_percent(self) -> float:
        """3 sigma of the whole PES in % of the track pitch."""
        return float(300.0 * np.std(self.pes))

    def spectrum(self, nperseg: int = 4096, which: str = "pes") -> tuple[np.ndarray, np.ndarray]:
        """One-sided Welch PSD [track^2/Hz] of ``"pes"`` or ``"nrpe"`` and its frequencies [Hz]."""
        data = {"pes": self.pes, "nrpe": self.nrpe}[which]
        n = min(check_count("nperseg", nperseg, lo=16), len(data))
        return welch_psd(data, 1.0 / self.dt, n)


def welch_psd(x: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD: ``scipy.signal.welch(x, fs, nperseg=nperseg)`` in numpy.

    SciPy's defaults: periodic Hann window, half-overlapping segments, each detrended by
    its mean, ``|rfft|^2 / (fs sum(w^2))`` doubled except at 0 and Nyquist, averaged
    over the segments; the two agree to ~1e-14 relative (tests/test_numpy_loops.py).
    scipy.signal's import alone costs more than a command's start-up budget (issue 23).

    Parameters
    ----------
    x : ndarray (n,)
        Real signal.
    fs : float
        Sampling rate [Hz].
    nperseg : int
        Segment length, ``<= n``.

    Returns
    -------
    freq_hz : ndarray
        ``nperseg // 2 + 1`` frequencies [Hz].
    psd : ndarray
        PSD [unit^2/Hz].
    """
    x = np.asarray(x, dtype=float)
    m = check_count("nperseg", nperseg, lo=1, hi=x.size)
    fac = np.linspace(-np.pi, np.pi, m + 1)  # scipy's general_cosine, sym=False
    win = (np.zeros(m + 1) + 0.5 * np.cos(0.0 * fac) + 0.5 * np.cos(1.0 * fac))[:-1]
    if m == 1:  # scipy's length guard: a one-point window is [1]
        win = np.ones(1)
    scale = 1.0 / (fs * (win * win).sum())
    step = m - m // 2
    n_seg = (x.size - m // 2) // step
    seg = np.lib.stride_tricks.as_strided(
        x, shape=(n_seg, m), strides=(step * x.strides[0], x.strides[0]), writeable=False
    )
    seg = win * (seg - np.mean(seg, axis=-1, keepdims=True))
    spec = np.fft.rfft(seg, n=m)
    spec = np.conjugate(spec) * spec
    spec *= scale
    spec[..., 1 : (None if m % 2 else -1)] *= 2
    psd = np.moveaxis(spec.real, -1, 0).mean(axis=-1)  # frequencies first, as scipy
    return np.fft.rfftfreq(m, 1.0 / fs), psd


def lifted_plant(
    plant: ModalPlant, dt: float, force_rate: int = 2, zoh: str = "expm"
) -> tuple[np.ndarray, ...]:
    """``(A, Bu, Bw, C)`` of the plant over one PES period (module docstring).

    ``Bw`` has one column per plant-input sample of force noise within the period.

    Parameters
    ----------
    plant : ModalPlant
        Plant.
    dt : float
        PES period [s].
    force_rate : int
        Plant-input samples per PES sample.
    zoh : {"expm", "modal"}
        The plant's exact ZOH (:meth:`ModalPlant.discretize_data`): ``scipy.linalg.expm``
        or closed form per mode (numpy only, the same to ~1e-13).

    Returns
    -------
    tuple of ndarray
    """
    r = check_count("force_rate", force_rate, lo=1, hi=64)
    sd = plant.discretize_data(dt / r, method=zoh)
    a, b, c = sd.A, sd.B, sd.C
    powers = [np.linalg.matrix_power(a, j) for j in range(r + 1)]  # r is small
    bw = np.hstack([powers[r - 1 - i] @ b for i in range(r)])
    return powers[r], bw.sum(axis=1, keepdims=True), bw, c


def pes_closed_loop(
    plant: ModalPlant, controller: control.LTI, dt: float, force_rate: int = 2
) -> control.StateSpace:
    """Closed loop at ``dt`` with inputs ``[w_1..w_r, d]`` (force [A], ``d = flutter + rro +
    sensor`` [track]) and outputs ``[PES, u]``.

    Parameters
    ----------
    plant : ModalPlant
        Plant.
    controller : discrete LTI
        ``C(z)`` at ``dt``.
    dt : float
        PES period [s].
    force_rate : int
        Plant-input samples per PES sample.

    Returns
    -------
    StateSpace
        Raises if the loop is unstable.
    """
    return pes_closed_loop_data(plant, controller, dt, force_rate).to_control()


def pes_closed_loop_data(
    plant: ModalPlant, controller: Any, dt: float, force_rate: int = 2, zoh: str = "expm"
) -> StateSpaceData:
    """:func:`pes_closed_loop` as numpy arrays, python-control left unloaded.

    Parameters
    ----------
    plant : ModalPlant
        Plant.
    controller : RationalTF, StateSpaceData or discrete python-control LTI
        ``C(z)`` at ``dt`` (a transfer function by its companion form, python-control's
        realisation).
    dt : float
        PES period [s].
    force_rate : int
        Plant-input samples per PES sample.
    zoh : {"expm", "modal"}
        The plant's ZOH, as :func:`lifted_plant`.

    Returns
    -------
    StateSpaceData
        Raises if the loop is unstable.
    """
    ap, bu, bw, cp = lifted_plant(plant, dt, force_rate, zoh)
    cs = as_state_space_data(controller)
    if not cs.dt or not np.isclose(cs.dt, dt, rtol=1e-9):
        raise ServokitValueError(f"controller must be discrete with dt = {dt:g} s")
    ac, bc, cc, dc = cs.A, cs.B, cs.C, cs.D
    m = ac.shape[0]
    a = np.block([[ap - bu @ dc @ cp, bu @ cc], [-bc @ cp, ac]])
    b = np.block([[bw, -bu @ dc], [np.zeros((m, bw.shape[1])), -bc]])
    c = np.block([[-cp, np.zeros((1, m))], [-dc @ cp, cc]])
    d = np.block(
        [[np.zeros((1, bw.shape[1])), -np.ones((1, 1))], [np.zeros((1, bw.shape[1])), -dc]]
    )
    if np.any(np.abs(np.linalg.eigvals(a)) >= 1.0):
        raise ServokitValueError("the closed loop is unstable with this controller and plant")
    return StateSpaceData(a, b, c, d, dt)


def track_following_pes(
    plant: ModalPlant,
    controller: control.LTI,
    record: DisturbanceRecord,
    *,
    samples_per_rev: int = 220,
    discard_revolutions: int = 5,
    max_memory_mb: float | None = None,
    zoh: str = "expm",
) -> PesResult:
    """Simulate track following under the benchmark disturbances (module docstring).

    Parameters
    ----------
    plant : ModalPlant
        Plant (input [A], output [track]).
    controller : discrete LTI or RationalTF
        ``C(z)`` at ``record.dt`` acting on the PES.
    record : DisturbanceRecord
        Disturbances from :meth:`BenchmarkDisturbances.generate`.
    samples_per_rev : int
        Sectors per revolution (for RPE / NRPE).
    discard_revolutions : int
        Leading revolutions dropped (start-up transient).
    max_memory_mb : float, optional
        Memory limit of the run [MB] (checked before allocating).
    zoh : {"expm", "modal"}
        The plant's ZOH, as :func:`lifted_plant` (``"modal"``: numpy only).

    Returns
    -------
    PesResult
    """
    spr = check_count("samples_per_rev", samples_per_rev, lo=4)
    drop = check_count("discard_revolutions", discard_revolutions, lo=0)
    if record.n % spr or record.n // spr <= drop:
        raise ServokitValueError("the record must hold whole revolutions, more than discarded")
    cl = pes_closed_loop_data(plant, controller, record.dt, record.force.shape[1], zoh)
    check_memory(
        8.0 * record.n * (2 * cl.ninputs + 2 * cl.noutputs + 2),  # inputs, blocks, outputs
        what="the PES run",
        max_memory_mb=max_memory_mb,
    )
    d = record.flutter + record.rro + record.sensor
    u_in = np.column_stack([record.force, d])  # (n, inputs)
    out = forced_outputs(cl.A, cl.B, cl.C, cl.D, u_in).T  # control.forced_response's
    keep = slice(drop * spr, None)
    return PesResult(out[0, keep], out[1, keep], record.dt, spr)
