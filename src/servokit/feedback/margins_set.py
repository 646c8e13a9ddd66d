"""Margins of one controller over a set of plants: per plant and the worst case.

The worst plant is an unstable closed loop if there is one (the first), otherwise the one
with the smallest modulus margin ``min |1 + L|``: that single number bounds both classical
margins (``GM >= 1/(1 - MM)``, ``PM >= 2 asin(MM/2)``), so it ranks loops whose gain and
phase margins disagree. The smallest gain, phase and delay margins over the set are
reported as well, each with the index of its plant.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedback.margins import Margins, stability_margins

__all__ = ["SetMargins", "margins_over_set"]


@dataclass(frozen=True)
class SetMargins:
    """Per-plant margins and the worst case over a plant set.

    Attributes
    ----------
    margins : tuple of Margins
        One per plant, in the order given.
    worst_index : int
        Index of the worst plant (unstable first, else smallest modulus margin).
    min_gain_margin_db, min_phase_margin_deg, min_delay_margin_s : float
        Smallest headline margins over the set (``|GM|`` nearest 0 dB for the gain margin).
    min_gain_margin_index, min_phase_margin_index, min_delay_margin_index : int
        Where they occur.
    all_stable : bool or None
        Whether every closed loop is stable (None if some verdict is unknown).
    """

    margins: tuple[Margins, ...]
    worst_index: int
    min_gain_margin_db: float
    min_gain_margin_index: int
    min_phase_margin_deg: float
    min_phase_margin_index: int
    min_delay_margin_s: float
    min_delay_margin_index: int
    all_stable: bool | None

    @property
    def worst(self) -> Margins:
        """Margins of the worst plant."""
        return self.margins[self.worst_index]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (snake_case keys with unit suffixes)."""
        return {
            "all_stable": self.all_stable,
            "worst_index": self.worst_index,
            "min_gain_margin_db": self.min_gain_margin_db,
            "min_gain_margin_index": self.min_gain_margin_index,
            "min_phase_margin_deg": self.min_phase_margin_deg,
            "min_phase_margin_index": self.min_phase_margin_index,
            "min_delay_margin_s": self.min_delay_margin_s,
            "min_delay_margin_index": self.min_delay_margin_index,
            "plants": [m.to_dict() for m in self.margins],
        }


def _as_loop(controller: Any, plant: Any) -> list[Any]:
    ctrl = list(controller) if isinstance(controller, list | tuple) else [controller]
    dts = {getattr(c, "dt", None) for c in ctrl} - {None, 0}
    if dts and hasattr(plant, "discretize") and hasattr(plant, "modes"):
        plant = plant.discretize(float(next(iter(dts))))  # exact ZOH with the plant's delay
    return [plant, *ctrl]


def _argmin(values: list[float]) -> int:
    arr = np.asarray(values, dtype=float)
    arr = np.where(np.isnan(arr), np.inf, arr)
    return int(np.argmin(arr))


def margins_over_set(
    controller: Any,
    plants: Sequence[Any],
    delay: float = 0.0,
    *,
    progress: Callable[[], object] | None = None,
    **kwargs: Any,
) -> SetMargins:
    """Margins of ``controller`` with each plant of ``plants``, and the worst plant.

    Parameters
    ----------
    controller : LTI, callable or sequence of them
        The controller factors (a discrete controller makes each
        :class:`~servokit.models.ModalPlant` be discretised exactly under a ZOH at its
        ``dt``, delay included).
    plants : sequence
        Plants (ModalPlant, LTI or callables), at least one.
    delay : float
        Extra loop delay [s], as in :func:`~servokit.feedback.stability_margins`.
    progress : callable, optional
        Called with no argument after each plant (e.g. a progress bar's ``advance``).
    **kwargs
        Passed on to :func:`~servokit.feedback.stability_margins` (``fmin``, ``fmax``,
        ``n_freq``).

    Returns
    -------
    SetMargins
    """
    plants = list(plants)
    if not plants:
        raise ServokitValueError("plants is empty; give at least one plant")
    found = []
    for p in plants:
        found.append(stability_margins(_as_loop(controller, p), delay, **kwargs))
        if progress is not None:
            progress()
    ms = tuple(found)
    unstable = [i for i, m in enumerate(ms) if m.closed_loop_stable is False]
    worst = unstable[0] if unstable else _argmin([m.modulus_margin for m in ms])
    verdicts = [m.closed_loop_stable for m in ms]
    all_stable = None if None in verdicts else all(verdicts)
    i_gm = _argmin([abs(m.gain_margin_db) for m in ms])
    i_pm = _argmin([m.phase_margin_deg for m in ms])
    i_dm = _argmin([m.delay_margin_s for m in ms])
    return SetMargins(
        margins=ms,
        worst_index=worst,
        min_gain_margin_db=ms[i_gm].gain_margin_db,
        min_gain_margin_index=i_gm,
        min_phase_margin_deg=ms[i_pm].phase_margin_deg,
        min_phase_margin_index=i_pm,
        min_delay_margin_s=ms[i_dm].delay_margin_s,
        min_delay_margin_index=i_dm,
        all_stable=all_stable,
    )
