"""Designs the export knows by name (the book's HDD benchmark feedforward inputs)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from servokit.errors import ServokitValueError, check_count, check_positive

if TYPE_CHECKING:
    from servokit.feedforward import FeedforwardInput

__all__ = ["hdd_feedforward"]


def hdd_feedforward(design: int, target: float, n_samples: int | None = None) -> FeedforwardInput:
    """The HDD benchmark feedforward of §2.4.2: Design 1 (FSC) or 2 (FFSC, Table 2.4).

    Parameters
    ----------
    design : int
        1 (minimum-jerk FSC, eqs. 2.40-2.42) or 2 (frequency-shaped FFSC, (2.74)-(2.75)).
    target : float
        Seek distance [track] (> 0).
    n_samples : int, optional
        Steps N; default the book's N for 1 track (up to 3 tracks) or 10 tracks.

    Returns
    -------
    servokit.feedforward.FeedforwardInput
        The held input, designed on the rigid-body model at Ts = 37.879 us.
    """
    from servokit.cases.hdd_seek import DESIGNS, SeekDesign
    from servokit.models import hdd_benchmark

    if design not in (1, 2):
        raise ServokitValueError(f"--design {design}: choose 1 (FSC) or 2 (FFSC)")
    target = check_positive("--target", target, "track")
    shaped = design == 2
    book = next(d for d in DESIGNS if d.shaped == shaped and (d.tracks > 3) == (target > 3))
    n = book.N if n_samples is None else check_count("--n-samples", n_samples, lo=2, hi=100_000)
    return SeekDesign("export", book.label, target, n, shaped).design(hdd_benchmark())
