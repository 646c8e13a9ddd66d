"""The multirate path of the book's sampled-data HDD example (§4.5.2, eqs. 4.66-4.68).

The controller runs at Ts = 153.5 us; the plant input is refreshed ``m = 4`` times per
sample through the interpolator ``Ip = 1 + z^-1 + z^-2 + z^-3`` (4.67), the filter ``Fm``
(4.68) with its resonant peak at 3.6 kHz, and a fast zero-order hold (4.66).
"""

from __future__ import annotations

import numpy as np

from servokit._lazy import control
from servokit.models.catalogue import HDD_SAMPLED_DATA_TS
from servokit.models.rational import RationalTF
from servokit.sampled.multirate import Multirate

__all__ = ["FILTER_HZ", "M", "hdd_multirate", "multirate_filter_4_68"]

#: multirate number of §4.5.2 (plant input refreshed m times per controller sample)
M = 4
#: centre of the resonant peak of Fm (4.68) [Hz]
FILTER_HZ = 3600.0


def multirate_filter_4_68(dt: float = HDD_SAMPLED_DATA_TS, m: int = M) -> control.TransferFunction:
    """``Fm``: ``Fmc(s) = 1 - 0.1 s^2 / (s^2 + 2 (0.003) wf s + wf^2)``, wf = 2 pi 3.6 kHz (4.68).

    Discretised at ``dt/m`` by Tustin with prewarping at ``wf``.

    Parameters
    ----------
    dt : float
        Controller sampling period ``Ts`` [s] (153.5 us).
    m : int
        Multirate number; the filter runs at ``dt/m``.

    Returns
    -------
    control.TransferFunction
        Discrete ``Fm(z)`` with sampling period ``dt/m``: gain 1 at low frequency, a
        resonant peak ``|1 + 0.1 j / 0.006|`` (about +24 dB) at 3.6 kHz and 0.9 (-0.9 dB)
        above it.
    """
    return _filter_4_68(dt, m).to_control()


def _filter_4_68(dt: float, m: int) -> RationalTF:
    """Fm of eq. (4.68) as numpy coefficients: python-control's Tustin arithmetic."""
    wf = 2.0 * np.pi * FILTER_HZ
    fmc = 1 - RationalTF([0.1, 0.0, 0.0], [1.0, 2 * 0.003 * wf, wf**2])
    return fmc.tustin(dt / m, prewarp_rad_s=wf)


def hdd_multirate(dt: float = HDD_SAMPLED_DATA_TS, m: int = M) -> Multirate:
    """Multirate path of §4.5.2: ``Ip = 1 + z^-1 + z^-2 + z^-3`` (4.67), ``Fm`` (4.68), ZOH.

    Parameters
    ----------
    dt : float
        Controller sampling period ``Ts`` [s] (153.5 us).
    m : int
        Multirate number (4 in §4.5.2); ``Ip = 1 + z^-1 + ... + z^-(m-1)``.

    Returns
    -------
    Multirate
        ``m``, ``Ip`` and ``Fm`` (:func:`multirate_filter_4_68`) at ``dt/m`` as numpy-only
        :class:`~servokit.models.rational.RationalTF` (python-control left unloaded; its
        ``chain`` and ``discretize`` still return python-control objects), fast
        zero-order hold (4.66).
    """
    ip = RationalTF(np.ones(m), np.r_[1.0, np.zeros(m - 1)], dt / m)
    return Multirate(m, interpolator=ip, filter=_filter_4_68(dt, m))
