"""Track-following PES simulation and evaluation as in the HDD Benchmark Problem.

Loop (one PES sample ``Ts``): the plant (modal, with delay) is discretised exactly at the
plant-input period ``Tu = Ts / r`` (``r = force_rate``) and lifted to ``Ts``:
``x[k+1] = A^r x[k] + sum_i A^(r-1-i) B (u[k] + w_i[k])``, where ``u`` is the controller
output held over ``Ts`` and ``w_i`` the force-noise samples; ``y = C x``.  The head sits at
``h = y + flutter + rro`` and the measured position error is ``PES = -(h + n)`` (target
track 0, ``n`` sensor noise); ``u = C(z) PES``.

Evaluation (benchmark ``PESEval``): RPE is the PES averaged sector by sector over the
revolutions; NRPE the rest; ``NRPE 3 sigma`` is reported in % of the track pitch; the
spectrum is a Welch PSD (scipy.signal).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit._lazy import scipy_signal as signal
from servokit.errors import ServokitValueError, check_count, check_memory
from servokit.models.disturbances import DisturbanceRecord
from servokit.models.modal import ModalPlant

__all__ = ["PesResult", "lifted_plant", "track_following_pes", "pes_closed_loop"]


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
        return signal.welch(data, fs=1.0 / self.dt, nperseg=n)


def lifted_plant(plant: ModalPlant, dt: float, force_rate: int = 2) -> tuple[np.ndarray, ...]:
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

    Returns
    -------
    tuple of ndarray
    """
    r = check_count("force_rate", force_rate, lo=1, hi=64)
    sd = plant.discretize(dt / r)
    a, b, c = np.asarray(sd.A), np.asarray(sd.B), np.asarray(sd.C)
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
    ap, bu, bw, cp = lifted_plant(plant, dt, force_rate)
    cs = control.ss(controller)
    if cs.dt is None or cs.dt is True or not np.isclose(float(cs.dt), dt, rtol=1e-9):
        raise ServokitValueError(f"controller must be discrete with dt = {dt:g} s")
    ac, bc, cc, dc = (np.asarray(m) for m in (cs.A, cs.B, cs.C, cs.D))
    m = ac.shape[0]
    a = np.block([[ap - bu @ dc @ cp, bu @ cc], [-bc @ cp, ac]])
    b = np.block([[bw, -bu @ dc], [np.zeros((m, bw.shape[1])), -bc]])
    c = np.block([[-cp, np.zeros((1, m))], [-dc @ cp, cc]])
    d = np.block(
        [[np.zeros((1, bw.shape[1])), -np.ones((1, 1))], [np.zeros((1, bw.shape[1])), -dc]]
    )
    cl = control.ss(a, b, c, d, dt)
    if np.any(np.abs(cl.poles()) >= 1.0):
        raise ServokitValueError("the closed loop is unstable with this controller and plant")
    return cl


def track_following_pes(
    plant: ModalPlant,
    controller: control.LTI,
    record: DisturbanceRecord,
    *,
    samples_per_rev: int = 220,
    discard_revolutions: int = 5,
    max_memory_mb: float | None = None,
) -> PesResult:
    """Simulate track following under the benchmark disturbances (module docstring).

    Parameters
    ----------
    plant : ModalPlant
        Plant (input [A], output [track]).
    controller : discrete LTI
        ``C(z)`` at ``record.dt`` acting on the PES.
    record : DisturbanceRecord
        Disturbances from :meth:`BenchmarkDisturbances.generate`.
    samples_per_rev : int
        Sectors per revolution (for RPE / NRPE).
    discard_revolutions : int
        Leading revolutions dropped (start-up transient).

    Returns
    -------
    PesResult
    """
    spr = check_count("samples_per_rev", samples_per_rev, lo=4)
    drop = check_count("discard_revolutions", discard_revolutions, lo=0)
    if record.n % spr or record.n // spr <= drop:
        raise ServokitValueError("the record must hold whole revolutions, more than discarded")
    cl = pes_closed_loop(plant, controller, record.dt, record.force.shape[1])
    check_memory(
        8.0 * record.n * (cl.nstates + cl.ninputs + 2),
        what="the PES run",
        max_memory_mb=max_memory_mb,
    )
    d = record.flutter + record.rro + record.sensor
    u_in = np.column_stack([record.force, d]).T
    out = control.forced_response(cl, U=u_in).outputs
    keep = slice(drop * spr, None)
    return PesResult(out[0, keep], out[1, keep], record.dt, spr)
