"""Parameter-variation sets of modal plants (book Table 2.3).

A :class:`VariationSet` holds a nominal plant and relative ranges on mode
frequencies, damping ratios and residues, on the input delay, and a loop-gain range.
It enumerates

* corner combinations (every range -- the gain range included -- at nominal / low /
  high, or grouped rows of changes applied together, as the HDD benchmark's fixed set
  of plants), and
* seeded Monte-Carlo samples, reproducibly: uniform within each range, or normal
  centred on the range with sigma = width / 6, clipped to the range (the range is the
  3-sigma box, and every sample stays inside it).

One :class:`Perturbation` draws one number: the modes it names move *together* (the
book's "f4,5,6,7 -2 %/+0.5 %" row is one such range).  For independent ranges give one
Perturbation per mode (:meth:`VariationSet.per_mode` and the variation files of
:mod:`servokit.models.variation_file` do).
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

Param = Literal["freq", "damping", "residue", "delay"]
Distribution = Literal["uniform", "normal"]
#: One level of a row: pairs of (index into ``VariationSet.ranges``, "low" | "high").
Level = tuple[tuple[int, str], ...]


@dataclass(frozen=True)
class Perturbation:
    """A relative range on one parameter of some modes (moved together), or on the delay.

    Parameters
    ----------
    param : {"freq", "damping", "residue", "delay"}
    modes : tuple of int
        1-based mode numbers, as in the book's tables (mode 1 = rigid body for the HDD);
        all of them take the same relative change.  Empty for ``"delay"``.
    low, high : float
        Relative change at each end, e.g. ``-0.02`` and ``+0.01`` for -2 % / +1 %.
    """

    param: Param
    modes: tuple[int, ...]
    low: float
    high: float

    def __post_init__(self) -> None:
        if self.param not in ("freq", "damping", "residue", "delay"):
            raise ServokitValueError(
                "Perturbation.param must be 'freq', 'damping', 'residue' or 'delay', "
                f"got {self.param!r}"
            )
        if (self.param == "delay") != (not self.modes):
            raise ServokitValueError(
                "Perturbation: give modes for 'freq'/'damping'/'residue' and none for 'delay'"
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
    delay = nominal.delay
    for p, rel in changes:
        if p.param == "delay":
            delay *= 1.0 + rel
        for i in p.modes:
            if not 1 <= i <= len(nominal.modes):
                raise ServokitValueError(
                    f"Perturbation mode {i} does not exist; "
                    f"the plant has modes 1..{len(nominal.modes)}"
                )
            table[p.param][i - 1] *= 1.0 + rel
    modes = tuple(Mode(f, z, r) for f, z, r in zip(freq, damp, res, strict=True))
    return nominal.replace(modes=modes, gain=nominal.gain * (1.0 + gain_rel), delay=delay)


def _levels(low: float, high: float) -> list[float]:
    """Nominal, low and high without repeats (a range ending at 0 has two levels)."""
    return list(dict.fromkeys((0.0, float(low), float(high))))


@dataclass(frozen=True)
class VariationSet:
    """A nominal plant with relative parameter ranges.

    Parameters
    ----------
    nominal : ModalPlant
    ranges : tuple of Perturbation
        One random number each (modes named together move together).
    gain : (float, float)
        Relative loop-gain range, e.g. ``(-0.1, 0.1)``.
    distribution : {"uniform", "normal"}
        How :meth:`draw` samples a range: uniformly, or normally around its midpoint with
        sigma = (high - low) / 6, clipped to the range.
    seed : int
        Default seed of :meth:`monte_carlo` and :meth:`draw`.
    name : str
        What the set describes (a variation file's ``name``).
    """

    nominal: ModalPlant
    ranges: tuple[Perturbation, ...]
    gain: tuple[float, float] = (0.0, 0.0)
    distribution: Distribution = "uniform"
    seed: int = 0
    name: str = ""

    def __post_init__(self) -> None:
        if self.distribution not in ("uniform", "normal"):
            raise ServokitValueError(
                f"distribution must be 'uniform' or 'normal', got {self.distribution!r}"
            )
        if self.gain[0] > self.gain[1] or self.gain[0] <= -1.0:
            raise ServokitValueError(
                f"gain range {self.gain} must have -1 < low <= high (relative changes)"
            )

    @classmethod
    def per_mode(
        cls,
        nominal: ModalPlant,
        *,
        freq_rel: float = 0.0,
        damping_rel: float = 0.0,
        residue_rel: float = 0.0,
        gain_rel: float = 0.0,
        delay_rel: float = 0.0,
        **kwargs: object,
    ) -> VariationSet:
        """Independent symmetric ranges (+-half-range) on every resonance of ``nominal``.

        Parameters
        ----------
        nominal : ModalPlant
            Nominal plant; its rigid-body modes (``freq_hz = 0``) are not varied (their
            residue is the loop gain's business).
        freq_rel, damping_rel, residue_rel : float
            Relative half-ranges applied to each resonance independently (0: none).
        gain_rel, delay_rel : float
            Relative half-ranges of the loop gain and the delay.
        **kwargs
            ``distribution``, ``seed``, ``name`` of the set.

        Returns
        -------
        VariationSet
        """
        ranges = []
        for i, m in enumerate(nominal.modes, start=1):
            if m.freq_hz == 0:
                continue
            for param, half in (("freq", freq_rel), ("damping", damping_rel)):
                if half:
                    ranges.append(Perturbation(param, (i,), -abs(half), abs(half)))  # type: ignore[arg-type]
            if residue_rel:
                ranges.append(Perturbation("residue", (i,), -abs(residue_rel), abs(residue_rel)))
        if delay_rel:
            ranges.append(Perturbation("delay", (), -abs(delay_rel), abs(delay_rel)))
        gain = (-abs(gain_rel), abs(gain_rel))
        return cls(nominal, tuple(ranges), gain=gain, **kwargs)  # type: ignore[arg-type]

    @property
    def n_corners(self) -> int:
        """Number of plants :meth:`corners` returns (computed without building them)."""
        n = len(_levels(*self.gain))
        for p in self.ranges:
            n *= len(_levels(p.low, p.high))
        return n

    def corners(self) -> list[ModalPlant]:
        """Full factorial over every range and the gain range at nominal / low / high.

        Returns
        -------
        list of ModalPlant
            The nominal plant first; a range with an end at 0 contributes two levels, a
            zero-width range (and a zero gain range) one.
        """
        levels = [_levels(p.low, p.high) for p in self.ranges]
        out = []
        for gain in _levels(*self.gain):
            for combo in itertools.product(*levels):
                changes = list(zip(self.ranges, combo, strict=True))
                out.append(_apply(self.nominal, changes, gain))
        return out

    def rows(self, rows: Sequence[Sequence[Level]]) -> list[ModalPlant]:
        """Combinations of grouped rows: each row is nominal or one of its levels.

        ``rows[r]`` lists the non-nominal levels of row ``r``; a level applies several
        ranges together (``(range_index, "low"|"high")`` pairs).  The product over rows,
        nominal first, is returned (3 x 3 x 2 = 18 plants for the HDD benchmark).

        Parameters
        ----------
        rows : sequence of sequence of Level
            Grouped levels per row.

        Returns
        -------
        list of ModalPlant
            Gain nominal.
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

    def monte_carlo(self, n: int, seed: int | None = None) -> list[ModalPlant]:
        """``n`` plants with every range and the gain drawn (reproducible by ``seed``).

        Parameters
        ----------
        n : int
            Number of plants.
        seed : int, optional
            Random seed (default :attr:`seed`).

        Returns
        -------
        list of ModalPlant
        """
        return self.from_draws(*self.draw(n, seed))

    def draw(self, n: int, seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The relative changes of :meth:`monte_carlo`: ``(draws (n, R), gains (n,))``.

        Kept as arrays so that large sets can be built chunk by chunk (:meth:`from_draws`).

        Parameters
        ----------
        n : int
            Number of draws.
        seed : int, optional
            Random seed (default :attr:`seed`).

        Returns
        -------
        draws : numpy.ndarray
            Relative change of each range, shape ``(n, len(ranges))``.
        gains : numpy.ndarray
            Relative gain change, shape ``(n,)``.
        """
        if n < 1:
            raise ServokitValueError(f"n must be >= 1 (got {n})")
        rng = np.random.default_rng(self.seed if seed is None else seed)
        if self.distribution == "uniform":
            return self._uniform_rows(rng, n, 0, n)
        lows = np.array([p.low for p in self.ranges] + [self.gain[0]])
        highs = np.array([p.high for p in self.ranges] + [self.gain[1]])
        z = rng.standard_normal(size=(n, lows.size))
        both = np.clip((lows + highs) / 2 + z * (highs - lows) / 6, lows, highs)
        return both[:, :-1], both[:, -1]

    @property
    def rows_drawable(self) -> bool:
        """Whether :meth:`draw_rows` makes rows of :meth:`draw` without the others (uniform
        draws: one 64-bit output of the generator per number)."""
        return self.distribution == "uniform"

    def draw_rows(
        self, n: int, seed: int | None, lo: int, hi: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``lo:hi`` of ``draw(n, seed)``, bit for bit.

        Uniform draws take one 64-bit output of NumPy's default generator (PCG64) per
        number, ranges row by row and then the gains, so the generator is advanced past
        the rows before ``lo`` (``PCG64.advance``) and only ``hi - lo`` rows are made: a
        Dask worker draws its own plants instead of receiving them.  Normal draws
        (ziggurat: a varying number of outputs per number) are made whole and sliced.

        Parameters
        ----------
        n : int
            Number of draws of the whole set.
        seed : int, optional
            Random seed (default :attr:`seed`).
        lo, hi : int
            Rows ``0 <= lo <= hi <= n``.

        Returns
        -------
        draws : numpy.ndarray
            Shape ``(hi - lo, len(ranges))``.
        gains : numpy.ndarray
            Shape ``(hi - lo,)``.
        """
        if n < 1 or not 0 <= lo <= hi <= n:
            raise ServokitValueError(f"need 0 <= lo <= hi <= n (got {lo}, {hi}, {n})")
        rng = np.random.default_rng(self.seed if seed is None else seed)
        if not (self.rows_drawable and type(rng.bit_generator) is np.random.PCG64):
            draws, gains = self.draw(n, seed)
            return draws[lo:hi].copy(), gains[lo:hi].copy()
        return self._uniform_rows(rng, n, lo, hi)

    def _uniform_rows(
        self, rng: np.random.Generator, n: int, lo: int, hi: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``lo:hi`` of the uniform draws of ``n`` rows from a fresh ``rng``: the
        ranges row by row, then the gains, in this order (the stream of earlier
        releases); one 64-bit output per number, so the rows before ``lo`` are skipped by
        advancing the generator."""
        width = len(self.ranges)
        lows = np.array([p.low for p in self.ranges])
        highs = np.array([p.high for p in self.ranges])
        if lo:
            rng.bit_generator.advance(lo * width)
        draws = rng.uniform(lows, highs, size=(hi - lo, width))
        if (n - hi) * width + lo:
            rng.bit_generator.advance((n - hi) * width + lo)  # to the gain of row lo
        gains = rng.uniform(self.gain[0], self.gain[1], size=hi - lo)
        return draws, gains

    def from_draws(self, draws: np.ndarray, gains: np.ndarray) -> list[ModalPlant]:
        """Plants for rows of relative changes (one per range) and relative gains.

        Parameters
        ----------
        draws : numpy.ndarray
            Shape ``(n, len(ranges))`` (or one row).
        gains : numpy.ndarray
            Shape ``(n,)`` (or a scalar).

        Returns
        -------
        list of ModalPlant
        """
        return [
            _apply(self.nominal, list(zip(self.ranges, row, strict=True)), g)
            for row, g in zip(np.atleast_2d(draws), np.atleast_1d(gains), strict=True)
        ]
