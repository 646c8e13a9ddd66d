"""Validation of settling judgements (book §6.2.3.4, Figs. 6.10-6.12).

For each seek, ``N_judge - N0`` compares the sample at which a method declares settling
with the actual settling sample ``N0``; a negative value is a *failure* (the output leaves
the bound after the judgement).  Methods: the SVM judge at a decision level, and the
conventional rule (inside the bound ``n_in_row`` samples in a row, judged on the last).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from servokit.errors import check_count, check_positive
from servokit.learn.judge import SettlingJudge
from servokit.learn.seeks import SETTLE_BOUND, SeekResponse

__all__ = ["JudgementStats", "conventional_judgement", "evaluate_judgements", "judgement_plot"]


@dataclass(frozen=True)
class JudgementStats:
    """``N_judge - N0`` per seek for one method (-1 judgements never fired are dropped)."""

    method: str
    delays: np.ndarray
    never: int = 0

    @property
    def failures(self) -> int:
        """Seeks judged settled before ``N0`` (the output leaves the bound later)."""
        return int(np.sum(self.delays < 0))

    @property
    def mean_delay(self) -> float:
        """Mean of ``N_judge - N0`` over the non-failed seeks [samples]."""
        ok = self.delays[self.delays >= 0]
        return float(np.mean(ok)) if ok.size else float("nan")

    def to_dict(self) -> dict[str, object]:
        return {
            "method": self.method,
            "failures": self.failures,
            "never_judged": self.never,
            "mean_delay_samples": self.mean_delay,
            "delays_samples": self.delays.tolist(),
        }


def conventional_judgement(
    output: np.ndarray, bound: float = SETTLE_BOUND, n_in_row: int = 5, *, start: int = 0
) -> int:
    """Sample at which the output has been inside ``+-bound`` ``n_in_row`` times in a row
    (counting from ``start``); -1 if never.

    Parameters
    ----------
    output : ndarray
        Output sequence [track] (target at 0).
    bound : float
        Allowable bound [track].
    n_in_row : int
        Consecutive in-bound samples required.
    start : int
        First sample counted.

    Returns
    -------
    int
        The judged sample, or -1.
    """
    bound = check_positive("bound", bound, "track")
    n = check_count("n_in_row", n_in_row, lo=1)
    inside = (np.abs(np.asarray(output)[start:]) <= bound).astype(int)
    run = np.convolve(inside, np.ones(n, dtype=int), mode="valid")  # run[k] covers k..k+n-1
    hit = np.flatnonzero(run == n)
    return int(start + hit[0] + n - 1) if hit.size else -1


def _stats(method: str, judged: list[int], n0: list[int]) -> JudgementStats:
    pairs = [(j, z) for j, z in zip(judged, n0, strict=True) if j >= 0]
    delays = np.array([j - z for j, z in pairs], dtype=int)
    return JudgementStats(method, delays, never=len(judged) - len(pairs))


def evaluate_judgements(
    responses: Sequence[SeekResponse],
    judge: SettlingJudge,
    *,
    levels: Sequence[float] = (0.0, -0.8),
    n_in_row: int = 5,
    from_input_end: bool = False,
) -> list[JudgementStats]:
    """Judge every seek by the conventional rule and by the SVM at each level.

    With ``from_input_end`` every method starts judging at the end of the FSC input.

    Parameters
    ----------
    responses : sequence of SeekResponse
        Validation seeks.
    judge : SettlingJudge
        Fitted judge (its ``bound`` is used by every method).
    levels : sequence of float
        SVM decision levels to evaluate.
    n_in_row : int
        Samples in a row of the conventional rule.
    from_input_end : bool
        Start judging at the end of the FSC input.

    Returns
    -------
    list of JudgementStats
        Conventional rule first, then one entry per level.
    """
    n0 = [r.n0(judge.bound) for r in responses]
    start = [r.n_input if from_input_end else 0 for r in responses]
    conv = [
        conventional_judgement(r.output, judge.bound, n_in_row, start=s)
        for r, s in zip(responses, start, strict=True)
    ]
    out = [_stats(f"conventional ({n_in_row} in a row)", conv, n0)]
    scored = _svm_scores(responses, judge, start, stop_below=min(levels, default=0.0))
    for lvl in levels:
        svm = [int(i[f < lvl][0]) if np.any(f < lvl) else -1 for i, f in scored]
        out.append(_stats(f"SVM, level {lvl:g}", svm, n0))
    return out


def _svm_scores(
    responses: Sequence[SeekResponse],
    judge: SettlingJudge,
    start: Sequence[int],
    *,
    stop_below: float = -np.inf,
    chunk: int = 32,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per seek: its in-bound samples from ``start`` on and the SVM's ``f(x)`` there, up
    to the first sample with ``f(x) < stop_below`` (all of them with the default).

    :meth:`SettlingJudge.judge` at any level ``>= stop_below`` is the first of these
    samples with ``f(x) < level``, so the samples after it need no score: scoring them
    (3000 samples a seek against 10-30 before the judgement) was 40 % of the
    ``svm-settling`` case.  The seeks are scored together in rounds of ``chunk``
    samples each (doubling every round); the SVM scores each row on its own, so the
    values are those of one call on every row.
    """
    inside = []
    for r, s in zip(responses, start, strict=True):
        i = np.flatnonzero(np.abs(np.asarray(r.output)) <= judge.bound)
        inside.append(i[i >= s])
    scores: list[list[np.ndarray]] = [[] for _ in responses]
    done = [0] * len(responses)
    active = [k for k, i in enumerate(inside) if i.size]
    while active:
        rows = [
            np.asarray(responses[k].states)[inside[k][done[k] : done[k] + chunk]] for k in active
        ]
        f = judge.decision_function(np.concatenate(rows))
        for k, part in zip(
            active, np.split(f, np.cumsum([len(x) for x in rows])[:-1]), strict=True
        ):
            scores[k].append(part)
            done[k] += len(part)
        active = [
            k for k in active if done[k] < inside[k].size and not np.any(scores[k][-1] < stop_below)
        ]
        chunk *= 2
    return [
        (i[:n], np.concatenate(f) if f else np.empty(0))
        for i, n, f in zip(inside, done, scores, strict=True)
    ]


def judgement_plot(
    stats: Sequence[JudgementStats], path: str | Path, *, figures: Sequence[str]
) -> Path:
    """Histograms of ``N_judge - N0`` per method, failures in red (Figs. 6.10-6.12).

    Parameters
    ----------
    stats : sequence of JudgementStats
        One panel each.
    path : str or Path
        Figure file (.png / .svg).
    figures : sequence of str
        Book figure number of each panel.

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    fig, axes = plt.subplots(len(stats), 1, figsize=(7, 2.4 * len(stats)), sharex=True)
    axes = np.atleast_1d(axes)
    hi = max(int(s.delays.max()) if s.delays.size else 0 for s in stats) + 1
    bins = np.arange(-1.5, hi + 1.5)
    for ax, s, fig_no in zip(axes, stats, figures, strict=True):
        clipped = np.maximum(s.delays, -1)  # every failure goes into the "failure" bin
        counts, _ = np.histogram(clipped, bins)
        centres = bins[:-1] + 0.5
        colours = ["tab:red" if c < 0 else "tab:blue" for c in centres]
        ax.bar(
            centres,
            counts,
            width=0.8,
            color=colours,
            label=f"failures {s.failures}, mean delay {s.mean_delay:.2f}",
        )
        ax.set_ylabel("number of seeks")
        ax.set_title(f"{fig_no}: {s.method}")
        ax.legend(loc="upper right")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("N_judge - N0 [samples] (-1 = failure)")
    return save_figure(fig, path)
