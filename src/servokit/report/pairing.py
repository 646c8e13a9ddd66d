"""Honest pairing of a computed list (peaks, roots, frequencies) with the book's numbers.

:func:`servokit.report.nearest` picks, for one book value, the closest computed item:
items that match nothing and book values that nothing matches disappear silently.
:func:`pair_rows` pairs one-to-one instead (``scipy.optimize.linear_sum_assignment`` on
the relative distances) and returns a row for every book value and every computed item:

* a book value paired within its printed precision: a normal row;
* a book value whose partner is outside its tolerance, or that has no partner (fewer
  computed items): a row that misses, with a note naming the nearest computed item;
* a computed item paired with no book value: a row with no book number
  (``within_tolerance`` null in ``results.json``) and a note saying so.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit.report import Comparison, printed_tolerance

__all__ = ["pair_rows"]


def _distance(book: np.ndarray, found: np.ndarray) -> np.ndarray:
    scale = np.maximum(np.abs(book)[:, None], np.finfo(float).tiny)
    return np.abs(found[None, :] - book[:, None]) / scale


def pair_rows(
    quantity: str,
    book_texts: Sequence[str],
    found: Sequence[float] | np.ndarray,
    *,
    floor: float = 0.0,
    **row: str,
) -> list[Comparison]:
    """Rows for the book's list ``book_texts`` against the computed list ``found``.

    Parameters
    ----------
    quantity : str
        Name of the listed quantity (``"resonance peak"``); rows are numbered ``#1 ...``.
    book_texts : sequence of str
        The book's numbers exactly as printed (tolerance from the printed precision).
    found : array_like
        The computed items, any order and count.
    floor : float
        Smallest relative tolerance of a row.
    **row : str
        Further :class:`Comparison` fields (``unit``, ``source``, ``kind``, ``note``).

    Returns
    -------
    list of Comparison
        One row per book value (in the book's order), then one per unpaired computed item.
    """
    from scipy.optimize import linear_sum_assignment

    items = np.asarray(found, dtype=float).ravel()
    values = np.array([float(t) for t in book_texts])
    cost = _distance(values, items)
    rows_i, cols_i = linear_sum_assignment(cost) if cost.size else ([], [])
    partner = dict(zip(rows_i, cols_i, strict=True))
    note = row.pop("note", "")
    out: list[Comparison] = []
    for i, text in enumerate(book_texts):
        j = partner.get(i)
        value = float(items[j]) if j is not None else float("nan")
        tol = printed_tolerance(text, floor=floor)
        why = "" if j is not None else "no computed item left to pair with this book value"
        if j is not None and cost[i, j] > tol:
            why = f"paired item {value:.6g} is outside the printed precision"
        out.append(
            Comparison.printed(
                f"{quantity} #{i + 1}", text, value, floor=floor,
                note="; ".join(p for p in (note, why) if p), **row,
            )
        )  # fmt: skip
    for j in sorted(set(range(items.size)) - set(cols_i)):
        out.append(
            Comparison(
                f"{quantity} (computed only)", float("nan"), float(items[j]),
                note="; ".join(p for p in (note, "computed item with no book counterpart") if p),
                **row,
            )
        )  # fmt: skip
    return out
