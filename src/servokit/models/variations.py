"""Parameter-variation sets of modal plants (book Table 2.3).

A :class:`VariationSet` holds a nominal plant and relative ranges on mode
frequencies, damping ratios and residues (and a loop-gain range).  It enumerates

* corner combinations (every range at its low / high end, or grouped rows of
  changes applied together, as the HDD benchmark's fixed set of plants), and
* seeded Monte-Carlo samples (uniform within each range), reproducibly.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models.modal import ModalPlant, Mode

__all__ = ["Perturbation", "VariationSet"]

Param = Literal["freq", "damping", "residue"]
#: One level of a row: pairs of (index into ``VariationSet.ranges``, "low" | "high").
Level = tuple[tuple[int, str], ...]


@dataclass(frozen=True)
class Perturbation:
    """A relative range on one parameter of some modes.

    Parameters
    ----------
    param : {"freq", "damping", "residue"}
    modes : tuple of int
        1-based mode numbers, as in the book's tables (mode 1 = rigid body for the HDD).
    low, high : float
        Relative change at each end, e.g. ``-0.02`` and ``+0.01`` for -2 % / +1 %.
    """

    param: Param
    modes: tuple[int, ...]
    low: float
    high: float

    def __post_init__(self) -> None:
        if self.param not in ("freq", "damping", "residue"):
            raise ServokitValueError(
                f"Perturbation.param must be 'freq', 'damping' or 'residue', got {self.param!r}"
            )
        if self.low > self.high:
            raise ServokitValueError(
                f"Perturbation low ({self.low}) must not exceed high ({self.high})"
            )


def _apply(
    nominal: ModalPlant, changes: Sequence[tuple[Perturbation, float]], gain_rel: float
) -> ModalPlant:
    freq = [m.freq_hz for m in nominal.modes]
    damp = [m.damping for m in nominal.modes]
    res = [m.residue for m in nominal.modes]
    table = {"freq": freq, "damping": damp, "residue": res}
    for p, rel in changes:
        for i in p.modes:
            if not 1 <= i <= len(nominal.modes):
                raise ServokitValueError(
                    f"Perturbation mode {i} does not exist; "
                    f"the plant has modes 1..{len(nominal.modes)}"
                )
            table[p.param][i - 1] *= 1.0 + rel
    modes = tuple(Mode(f, z, r) for f, z, r in zip(freq, damp, res, strict=True))
    return nominal.replace(modes=modes, gain=nominal.gain * (1.0 + gain_rel))


@dataclass(frozen=True)
class VariationSet:
    """A nominal plant with relative parameter ranges.

    Parameters
    ----------
    nominal : ModalPlant
    ranges : tuple of Perturbation
    gain : (float, float)
        Relative loop-gain range, e.g. ``(-0.1, 0.1)``.
    """

    nominal: ModalPlant
    ranges: tuple[Perturbation, ...]
    gain: tuple[float, float] = (0.0, 0.0)

    def corners(self) -> list[ModalPlant]:
        """Full factorial: every range at nominal / low / high (nominal plant first)."""
        levels = [(0.0, p.low, p.high) for p in self.ranges]
        out = []
        for combo in itertools.product(*levels):
            out.append(_apply(self.nominal, list(zip(self.ranges, combo, strict=True)), 0.0))
        return out

    def rows(self, rows: Sequence[Sequence[Level]]) -> list[ModalPlant]:
        """Combinations of grouped rows: each row is nominal or one of its levels.

        ``rows[r]`` lists the non-nominal levels of row ``r``; a level applies several
        ranges together (``(range_index, "low"|"high")`` pairs).  The product over rows,
        nominal first, is returned (3 x 3 x 2 = 18 plants for the HDD benchmark).
        """
        options = [[()] + [tuple(level) for level in row] for row in rows]
        out = []
        for combo in itertools.product(*options):
            changes = []
            for level in combo:
                for idx, end in level:
                    if end not in ("low", "high"):
                        raise ServokitValueError(f"level end must be 'low' or 'high', got {end!r}")
                    p = self.ranges[idx]
                    changes.append((p, p.low if end == "low" else p.high))
            out.append(_apply(self.nominal, changes, 0.0))
        return out

    def monte_carlo(self, n: int, seed: int = 0) -> list[ModalPlant]:
        """``n`` plants with every range and the gain drawn uniformly (reproducible by ``seed``)."""
        return self.from_draws(*self.draw(n, seed))

    def draw(self, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The relative changes of :meth:`monte_carlo`: ``(draws (n, R), gains (n,))``.

        Kept as arrays so that large sets can be built chunk by chunk (:meth:`from_draws`).
        """
        if n < 1:
            raise ServokitValueError(f"n must be >= 1 (got {n})")
        rng = np.random.default_rng(seed)
        lows = np.array([p.low for p in self.ranges])
        highs = np.array([p.high for p in self.ranges])
        draws = rng.uniform(lows, highs, size=(n, len(self.ranges)))
        gains = rng.uniform(self.gain[0], self.gain[1], size=n)
        return draws, gains

    def from_draws(self, draws: np.ndarray, gains: np.ndarray) -> list[ModalPlant]:
        """Plants for rows of relative changes (one per range) and relative gains."""
        return [
            _apply(self.nominal, list(zip(self.ranges, row, strict=True)), g)
            for row, g in zip(np.atleast_2d(draws), np.atleast_1d(gains), strict=True)
        ]
