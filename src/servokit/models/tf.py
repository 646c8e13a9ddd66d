"""Transfer-function helpers: a leaf module (imports only numpy, python-control, errors).

:func:`zpk` builds a real transfer function from zeros, poles and gain; :func:`require_proper`
checks a SISO system is realisable.  Every other models/ module may import this one; it
imports none of them, so ``catalogue``, ``controllers`` and ``files`` form no circle.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError

__all__ = ["zpk", "require_proper"]


def zpk(
    zeros: Sequence[complex], poles: Sequence[complex], gain: float, dt: float | None = None
) -> control.TransferFunction:
    """Transfer function ``gain * prod(x - z) / prod(x - p)`` (x = s or z), real coefficients.

    Parameters
    ----------
    zeros, poles : sequence of complex
        Zeros and poles; complex ones in conjugate pairs.  Empty for none.
    gain : float
        Leading coefficient of the numerator (not the DC gain).
    dt : float, optional
        Sampling period [s] for a discrete transfer function (``x = z``); continuous
        (``x = s``) if omitted.

    Returns
    -------
    control.TransferFunction
        SISO transfer function with real polynomial coefficients.

    Raises
    ------
    ServokitValueError
        If the zeros or poles are not closed under conjugation (complex coefficients).
    """
    from servokit.models.rational import rational_zpk

    return rational_zpk(zeros, poles, gain, dt).to_control()


def require_proper(name: str, sys: control.LTI) -> None:
    """Raise unless the SISO transfer function ``sys`` is proper (realisable, causal).

    Parameters
    ----------
    name : str
        The system's name in the error message.
    sys : control.LTI or RationalTF
        SISO system; a transfer function is checked (numerator degree, after leading
        zeros are trimmed, at most the denominator's), a ``StateSpace`` is always proper.

    Raises
    ------
    ServokitValueError
        If ``sys`` has more zeros than poles.
    """
    # a transfer function: python-control's or a RationalTF (no python-control import)
    if getattr(sys, "den", None) is not None:
        num = np.trim_zeros(np.atleast_1d(np.asarray(sys.num[0][0], dtype=float)), "f")
        den = np.trim_zeros(np.atleast_1d(np.asarray(sys.den[0][0], dtype=float)), "f")
        if len(num) > len(den):
            raise ServokitValueError(
                f"{name} is not proper (more zeros than poles) and cannot be realised; "
                "add poles or a delay"
            )
