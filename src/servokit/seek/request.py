"""One seek design over a plant set: a checked request and :func:`design_seek`.

The seek command, the Monte-Carlo sweep, the robust seek and the firmware export all
design their input here, so the three methods have one implementation:

* ``"fsc"`` — minimum-jerk final-state control (2.40)-(2.42);
* ``"ffsc"`` — frequency-shaped FSC with band weights (2.74)-(2.75);
* ``"robust"`` — the LP of :func:`~servokit.seek.robust_minimum_time`, the shortest
  seek guaranteed on the whole set under ``|u| <= u_max``.

With ``N="auto"`` the FSC/FFSC step number is searched as in §2.4.2
(:func:`~servokit.seek.choose_N`: the smallest worst-case seek time over the plants);
the robust LP scans N itself.  Errors name the request's fields (parameter names).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_finite, check_positive
from servokit.feedforward import FeedforwardInput, fsc_input
from servokit.models.modal import ModalPlant, without_delay
from servokit.seek.outcome import BAND, SeekOutcome, simulate_seek
from servokit.seek.robust import RobustFeedforwardInput, robust_minimum_time
from servokit.seek.search import NSearchResult, choose_N
from servokit.simulate.metrics import seek_time

__all__ = ["METHODS", "SeekDesignResult", "SeekRequest", "SeekRun", "design_seek", "run_seek"]

#: the design methods of :class:`SeekRequest`
METHODS = ("fsc", "ffsc", "robust")
#: fewest steps the automatic N search of FSC/FFSC starts from
SMALLEST_N = 3

BandWeight = tuple[float, float, float, int]


@dataclass(frozen=True)
class SeekRequest:
    """A seek design over a plant set, checked on construction.

    Attributes
    ----------
    plants : sequence of ModalPlant
        Plants the input is evaluated on (the robust LP designs on all of them); the
        first is the nominal one.
    dt : float
        Hold period of the input [s].
    target : float
        Seek distance (plant output units; tracks for the HDD), non-zero.
    band : float
        Settling band half-width around ``target`` (same unit).
    method : {"fsc", "ffsc", "robust"}
        Design method.
    N : int or "auto"
        Step number, or ``"auto"`` for the search (FSC/FFSC: over ``N_range``; robust:
        the LP's own scan up to ``N_max``).
    N_range : iterable of int, optional
        Candidate N of the FSC/FFSC search; default ``3 .. N_max`` (``N_max`` required).
    N_max : int, optional
        Largest N searched.
    band_weights : sequence of (f_low_hz, f_high_hz, weight, n_points)
        FFSC band weights (2.74)-(2.75); required for ``"ffsc"``, refused otherwise.
    model : {"rigid-body", "plant"}
        FSC/FFSC design model (the book designs on the rigid body).
    u_max, slew_max : float, optional
        Robust: input limit (required) and per-sample slew limit.
    limits : sequence of constraint objects
        Limits of §2.6 (:class:`~servokit.feedforward.VoltageLimit`,
        :class:`~servokit.feedforward.InputLimit`, ...): the ``constraints`` of the
        FSC/FFSC design (the constrained QP) or the ``limits`` of the robust LP.
    margin : float
        Robust: band shrink in [0, 1).
    objective : {"peak", "energy"}
        Robust: second-stage objective.
    simulate_delay : bool
        Simulate (and design the robust LP on) the plants' input delay; ``False`` removes
        it, the book's §2.4 convention.
    design_plant : ModalPlant, optional
        FSC/FFSC design model's plant; default the first of ``plants``.
    max_memory_mb : float, optional
        Robust: memory limit of the LP (its estimate is checked before it is built).
    """

    plants: Sequence[ModalPlant]
    dt: float
    target: float
    band: float = BAND
    method: Literal["fsc", "ffsc", "robust"] = "fsc"
    N: int | Literal["auto"] = "auto"
    N_range: Iterable[int] | None = None
    N_max: int | None = None
    band_weights: Sequence[BandWeight] = ()
    model: str = "rigid-body"
    u_max: float | None = None
    slew_max: float | None = None
    limits: Sequence[object] = ()
    margin: float = 0.2
    objective: str = "peak"
    simulate_delay: bool = True
    design_plant: ModalPlant | None = field(default=None, repr=False)
    max_memory_mb: float | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ServokitValueError(
                f"method must be 'fsc', 'ffsc' or 'robust', got {self.method!r}"
            )
        if not self.plants:
            raise ServokitValueError("plants is empty; pass at least one ModalPlant")
        object.__setattr__(self, "plants", tuple(self.plants))
        check_positive("dt", self.dt, "s")
        if float(check_finite("target", self.target)) == 0:
            raise ServokitValueError("target must be non-zero (a seek distance)")
        check_positive("band", self.band)
        if self.N != "auto":
            check_count("N", self.N, lo=1)
        if self.method == "robust":
            self._check_robust()
        else:
            self._check_fsc()

    def _check_fsc(self) -> None:
        if self.model not in ("rigid-body", "plant"):
            raise ServokitValueError(f"model must be 'rigid-body' or 'plant', got {self.model!r}")
        if self.method == "ffsc" and not self.band_weights:
            raise ServokitValueError("method 'ffsc' needs at least one band in band_weights")
        if self.method != "ffsc" and self.band_weights:
            raise ServokitValueError("band_weights only applies to method 'ffsc'")
        if self.N == "auto" and self.N_range is None and self.N_max is None:
            raise ServokitValueError("N 'auto' needs N_range or N_max (the candidate steps)")

    def _check_robust(self) -> None:
        if self.u_max is None:
            raise ServokitValueError("method 'robust' needs u_max (input limit)")
        check_positive("u_max", self.u_max)
        if self.slew_max is not None:
            check_positive("slew_max", self.slew_max)
        if not 0.0 <= self.margin < 1.0:
            raise ServokitValueError(
                f"margin must be in [0, 1) (fraction of the band), got {self.margin}"
            )
        if self.objective not in ("peak", "energy"):
            raise ServokitValueError(
                f"objective must be 'peak' or 'energy', got {self.objective!r}"
            )

    def simulated_plants(self) -> list[ModalPlant]:
        """The plants as simulated: their input delay removed unless ``simulate_delay``.

        Returns
        -------
        list of ModalPlant
            ``plants``, or their copies without delay.
        """
        return list(self.plants) if self.simulate_delay else without_delay(self.plants)

    def candidates(self) -> list[int]:
        """Candidate N of the FSC/FFSC search.

        Returns
        -------
        list of int
            ``N_range`` if given, else ``3 .. N_max``.
        """
        if self.N_range is not None:
            return list(self.N_range)
        assert self.N_max is not None  # checked in __post_init__
        return list(range(SMALLEST_N, int(self.N_max) + 1))


@dataclass(frozen=True, eq=False)
class SeekDesignResult:
    """The input :func:`design_seek` designed, with its N search when ``N="auto"``.

    Attributes
    ----------
    ff : FeedforwardInput or RobustFeedforwardInput
        The held input.
    search : NSearchResult or None
        The FSC/FFSC search over N (``None`` for a fixed N or the robust LP, whose scan
        is in ``ff.N_values`` / ``ff.seek_times``).
    request : SeekRequest
        What was designed.
    """

    ff: FeedforwardInput | RobustFeedforwardInput
    search: NSearchResult | None
    request: SeekRequest


def design_seek(
    request: SeekRequest, progress: Callable[[], Any] | None = None
) -> SeekDesignResult:
    """Design the seek input a :class:`SeekRequest` asks for (§2.3-§2.4, robust LP).

    Parameters
    ----------
    request : SeekRequest
        The checked request.
    progress : callable, optional
        Called with no argument after each candidate N is evaluated (FSC/FFSC search).

    Returns
    -------
    SeekDesignResult
        The input and, for the FSC/FFSC search, every N tried.

    Raises
    ------
    ServokitValueError
        No N settles every plant; for the robust LP a
        :class:`~servokit.seek.NoFeasibleSeekError` naming what to relax.
    """
    if request.method == "robust":
        return SeekDesignResult(_robust(request), None, request)
    design = request.plants[0] if request.design_plant is None else request.design_plant
    kw: dict[str, Any] = {"band_weights": list(request.band_weights), "model": request.model}
    if request.limits:
        kw["constraints"] = tuple(request.limits)
    if request.N != "auto":
        ff = fsc_input(design, request.dt, int(request.N), request.target, **kw)
        return SeekDesignResult(ff, None, request)
    timed = seek_time
    if progress is not None:

        def timed(*args: Any, **k: Any) -> np.ndarray:
            progress()
            return seek_time(*args, **k)

    search = choose_N(
        request.simulated_plants(),
        request.dt,
        request.target,
        request.candidates(),
        design_plant=design,
        band=request.band,
        seek_time_fn=timed,
        **kw,
    )
    return SeekDesignResult(search.ff, search, request)


def _robust(request: SeekRequest) -> RobustFeedforwardInput:
    assert request.u_max is not None  # checked in __post_init__
    return robust_minimum_time(
        request.simulated_plants(),
        request.dt,
        request.target,
        band=request.band,
        u_max=request.u_max,
        N=None if request.N == "auto" else int(request.N),
        N_max=request.N_max,
        margin=request.margin,
        slew_max=request.slew_max,
        limits=tuple(request.limits) or None,
        objective=request.objective,  # type: ignore[arg-type]
        max_memory_mb=request.max_memory_mb,
    )


@dataclass(frozen=True, eq=False)
class SeekRun:
    """A designed seek input and its simulated seek over the request's plant set.

    Attributes
    ----------
    design : SeekDesignResult
        The input (and its N search).
    outcome : SeekOutcome
        The seek of every plant of ``request.simulated_plants()`` (read on the dt/10 grid).
    design_time_s : float
        Wall time of the design [s].
    """

    design: SeekDesignResult
    outcome: SeekOutcome
    design_time_s: float

    @property
    def ff(self) -> FeedforwardInput | RobustFeedforwardInput:
        """The designed input."""
        return self.design.ff


def run_seek(request: SeekRequest, progress: Callable[[], Any] | None = None) -> SeekRun:
    """Design the input of ``request`` (:func:`design_seek`) and simulate its seek (§2.4.1).

    Parameters
    ----------
    request : SeekRequest
        The checked request.
    progress : callable, optional
        As in :func:`design_seek`.

    Returns
    -------
    SeekRun
        The design, the seek time of every simulated plant, the design time.  A robust
        input is simulated far beyond its length (20 times, at least 20 ms more), so its
        tail bound is checked by the ordinary simulator, not only by the LP.
    """
    import time

    t0 = time.perf_counter()
    design = design_seek(request, progress)
    design_time = time.perf_counter() - t0
    ff = design.ff
    horizon = max(20 * ff.duration, ff.duration + 0.02) if request.method == "robust" else None
    outcome = simulate_seek(
        request.simulated_plants(), ff, request.target, band=request.band, horizon=horizon
    )
    return SeekRun(design, outcome, design_time)
