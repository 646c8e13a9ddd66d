"""The HDD benchmark seek designs of §2.4.2: Table 2.4's band weights and the book's N.

Design 1 is the minimum-jerk FSC input (2.40)-(2.42) of the rigid-body model; Design 2
the frequency-shaped FFSC input with the per-mode band cost (2.74)-(2.75) and the
weights of Table 2.4, also designed on the rigid-body model, both held at
Ts = 37.879 us.  The seek command, the export and the book case all design from here.
"""

from __future__ import annotations

from dataclasses import dataclass

from servokit.feedforward import FeedforwardInput, fsc_input
from servokit.models import HDD_BENCHMARK_TS, ModalPlant
from servokit.seek.outcome import BAND
from servokit.simulate.metrics import READOUT_SUBSTEPS

__all__ = [
    "BAND",
    "DESIGNS",
    "POINTS_PER_BAND",
    "SUBSTEPS",
    "SeekDesign",
    "search_range",
    "table_2_4_weights",
]

#: Read-out points per hold period of the benchmark (§2.4.1, assumption 4).
SUBSTEPS = READOUT_SUBSTEPS
#: Frequency points per band, "l_i = 60 for all i" (§2.4.2).
POINTS_PER_BAND = 60

# Table 2.4 (design parameters of Design 2): mode i, f_li, f_hi [Hz], q_i (1 track), q_i (10 tracks)
_TABLE_2_4 = (
    (3, 3895.0, 4305.0, 5e9, 5e9),
    (4, 4900.0, 5050.0, 2e8, 2e8),
    (5, 6860.0, 7070.0, 1e10, 5e10),
    (6, 12054.0, 12423.0, 2e9, 1e9),
    (7, 16072.0, 16564.0, 0.0, 1e8),
)


def table_2_4_weights(tracks: float) -> list[tuple[float, float, float, int]]:
    """Band weights of Table 2.4 for ``fsc_input``: the 1-track column for seeks up to
    3 tracks, the 10-track column beyond (the book gives only those two distances).

    Parameters
    ----------
    tracks : float
        Seek distance [track] (sign ignored).

    Returns
    -------
    list of (float, float, float, int)
        ``(f_low [Hz], f_high [Hz], q_i, 60)`` for modes 3-7 of Table 2.4, the
        ``band_weights`` of :func:`~servokit.feedforward.fsc_input`; a zero ``q_i`` (mode 7,
        1-track column) leaves that band out of the cost.
    """
    col = 3 if abs(tracks) <= 3 else 4
    return [(row[1], row[2], row[col], POINTS_PER_BAND) for row in _TABLE_2_4]


def search_range(tracks: float) -> range:
    """Candidate step numbers for the N search: a window set by the seek distance only
    (about 0.23-0.68 ms for short seeks, 0.45-1.25 ms for 10 tracks), not by the book's N.

    Parameters
    ----------
    tracks : float
        Seek distance [track] (sign ignored).

    Returns
    -------
    range
        ``N = 6..18`` for seeks up to 3 tracks, ``N = 12..33`` beyond.
    """
    return range(6, 19) if abs(tracks) <= 3 else range(12, 34)


@dataclass(frozen=True)
class SeekDesign:
    """One row of §2.4.2: design method, seek distance and the book's step number."""

    key: str
    label: str
    tracks: float
    N: int
    shaped: bool

    def band_weights(self) -> list[tuple[float, float, float, int]]:
        return table_2_4_weights(self.tracks) if self.shaped else []

    def design(self, nominal: ModalPlant, N: int | None = None) -> FeedforwardInput:
        return fsc_input(
            nominal,
            HDD_BENCHMARK_TS,
            self.N if N is None else N,
            self.tracks,
            band_weights=self.band_weights(),
            model="rigid-body",
        )


DESIGNS = (
    SeekDesign("d1-1", "Design 1 (FSC), 1 track", 1.0, 12, False),
    SeekDesign("d1-10", "Design 1 (FSC), 10 tracks", 10.0, 26, False),
    SeekDesign("d2-1", "Design 2 (FFSC), 1 track", 1.0, 10, True),
    SeekDesign("d2-10", "Design 2 (FFSC), 10 tracks", 10.0, 17, True),
)
