"""Monte-Carlo draws straight to modal arrays, without per-variant plant objects (issue 24).

:meth:`VariationSet.from_draws` builds one :class:`~servokit.models.ModalPlant` (and its
``Mode`` objects) per variant; the simulator then reads them back into arrays.  At 10^5
variants that round trip was 57.5 % of a seek-time sweep and the plant bank another
16.5 %, more than the simulation itself.  :func:`modal_arrays_from_draws` applies the
same relative changes to the nominal plant's parameter arrays for all variants at once,
in the same order (``param *= 1 + rel`` per range, then the gain), so the arrays equal
those of the plant path bit for bit.
"""

from __future__ import annotations

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models.variations import VariationSet

__all__ = ["modal_arrays_from_draws"]


def modal_arrays_from_draws(
    vset: VariationSet, draws: np.ndarray, gains: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(w, zeta, r, real)`` (V, M) of the plants ``vset.from_draws(draws, gains)``.

    Parameters
    ----------
    vset : VariationSet
        Nominal plant and ranges.
    draws : numpy.ndarray
        Relative changes (V, R), one column per range of ``vset`` (from ``vset.draw``).
    gains : numpy.ndarray
        Relative gain changes (V,).

    Returns
    -------
    w : numpy.ndarray
        Natural frequencies [rad/s], ``2 pi f``.
    zeta : numpy.ndarray
        Damping ratios.
    r : numpy.ndarray
        Input gains ``gain * residue`` of the modes.
    real : numpy.ndarray of bool
        All True (every variant has the nominal's modes), as the simulator's plant bank
        expects.

    Raises
    ------
    ServokitValueError
        If a range names a mode the nominal plant does not have, or the shapes disagree.
    """
    draws = np.atleast_2d(np.asarray(draws, dtype=float))
    gains = np.atleast_1d(np.asarray(gains, dtype=float))
    V, M = draws.shape[0], len(vset.nominal.modes)
    if draws.shape[1] != len(vset.ranges) or gains.shape != (V,):
        raise ServokitValueError(
            f"draws must be (n, {len(vset.ranges)}) and gains (n,), got {draws.shape} and "
            f"{gains.shape}"
        )
    nominal = np.array([[m.freq_hz, m.damping, m.residue] for m in vset.nominal.modes])
    table = {
        name: np.repeat(nominal[None, :, k], V, axis=0)
        for k, name in enumerate(("freq", "damping", "residue"))
    }
    for j, p in enumerate(vset.ranges):
        for i in p.modes:
            if not 1 <= i <= M:
                raise ServokitValueError(
                    f"Perturbation mode {i} does not exist; the plant has modes 1..{M}"
                )
            table[p.param][:, i - 1] *= 1.0 + draws[:, j]
    gain = vset.nominal.gain * (1.0 + gains)
    w = 2.0 * np.pi * table["freq"]
    return w, table["damping"], gain[:, None] * table["residue"], np.ones((V, M), dtype=bool)
