"""Loop response at a few points to full accuracy, for the final refinement of crossings.

The fast loop evaluator (:func:`~servokit.feedback.factor_response.loop_evaluator`) sums
partial fractions ``d + Σ r_i / (x − λ_i)``. Its terms carry the rounding of the poles and
residues (relative ``δ`` of a few ε, more for nearby poles), so its relative error is about
``κ δ`` with the cancellation ratio

    κ(x) = (Σ |r_i / (x − λ_i)| + |d|) / |d + Σ r_i / (x − λ_i)|.

κ is small at the crossings of most loops but large near clustered poles: for
``1/((s+12)(s+12.5)(s+12.546875))`` the partial fractions are 7.6e-7 relative off at the
phase crossover (Horner on the coefficients: 2e-16), which moved the critical gain by
1.5e-6 (``tests/test_margins_accuracy.py`` measures both). Here a factor's
partial-fraction value is kept where ``κ <= KAPPA_MAX``; elsewhere the factor's
:attr:`~servokit.feedback.factor_response.Factor.exact` form is evaluated and taken when
its own error amplification is smaller than κ: Horner on a transfer function's
coefficients (what they define) in long double, with Horner's running error bound; for a
state space an LU solve of ``(xI − A) y = B`` on the system's own matrices, as
python-control evaluates it (a Schur back substitution mixes the scales of a badly
scaled ZOH image and lost 4e-8 relative on the §5.2 dual-stage plant). Factors without
partial fractions (Schur forms, ModalPlants, callables) are evaluated as they are. Where
no partial fractions cancel, the values equal the fast evaluator's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from servokit.feedback.factor_response import Factor, merged_sums

__all__ = ["KAPPA_MAX", "accurate_evaluator"]

#: Largest cancellation ratio κ at which a partial-fraction value is kept (error ~ κ δ,
#: δ a few ε: 1e-13 relative at κ = 100).
KAPPA_MAX = 100.0


def accurate_evaluator(
    factors: list[Factor], tau: float, dt: float | None
) -> Callable[[np.ndarray], np.ndarray]:
    """``L(freq_hz)`` with every factor to full accuracy (see the module text).

    Parameters
    ----------
    factors : list of Factor
        The loop factors (one sampling period ``dt``).
    tau : float
        Extra delay [s], applied exactly as ``e^{-j 2π f τ}``.
    dt : float or None
        Sampling period [s] (None: continuous).

    Returns
    -------
    callable
        ``freq_hz -> complex ndarray``; as fast as the loop evaluator where no partial
        fractions cancel, meant for a few points per root elsewhere.
    """
    merged = [fa for fa in factors if fa.pf is not None]
    others = [fa for fa in factors if fa.pf is None]
    sums = merged_sums(merged)

    def resp(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        flat = f.ravel()
        out = np.exp(-2j * np.pi * flat * tau) if tau else np.ones(flat.shape, dtype=complex)
        x = np.exp(2j * np.pi * flat * dt) if dt is not None else 2j * np.pi * flat
        vals, size = sums(x, True)
        with np.errstate(invalid="ignore"):
            bad = ~(size <= KAPPA_MAX * np.abs(vals))  # NaN (a pole on the point) too
        for k in np.nonzero(bad.any(axis=1))[0]:
            exact = merged[k].exact
            if exact is not None:
                # the form with the smaller error amplification: kappa for the fractions
                v, amp = exact(flat[bad[k]])
                better = ~(amp >= size[k, bad[k]] / np.abs(vals[k, bad[k]]))
                vals[k, np.nonzero(bad[k])[0][better]] = v[better]
        out = out * np.prod(vals, axis=0)
        for fa in others:  # no fractions: the exact form (long-double Horner, LU) if any
            out = out * (fa.response(flat) if fa.exact is None else fa.exact(flat)[0])
        return out.reshape(f.shape)

    return resp
