"""Alias terms ``W Pc / Ts`` at ``f + l/dt`` of the sampled-data sums (book eqs. 4.4, 4.25).

Vectorised over the (frequency x alias order) grid for
:mod:`servokit.sampled.sensitivity`: the hold and its multirate filter factored per
residue of the order, the modal sum in real arithmetic one mode at a time, the delay as
an outer product.  :func:`_per_cell_path_terms` is the straightforward evaluation it
replaced, kept as the reference of the tests and of ``make bench``.
"""

from __future__ import annotations

import numpy as np

from servokit.models.modal import ModalPlant
from servokit.sampled.multirate import Multirate, zoh_response

__all__: list[str] = []


def _hold_filter(mr: Multirate, dt: float, f: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """``W(f + l/dt)`` (hold at ``T = dt/m`` times ``Ip Fm``), (len(f), len(orders)).

    With ``x = (f + l/dt) T = x_r + n`` (``r = l mod m``, ``n`` an integer) the hold
    ``T e^{-j pi x} sin(pi x) / (pi x)`` has ``e^{-j pi x} sin(pi x) = e^{-j pi x_r}
    sin(pi x_r)`` (the signs ``(-1)^n`` cancel), and ``Ip Fm`` at ``dt/m`` repeats with
    period ``m`` in ``l``: the transcendental part is evaluated per frequency and
    residue, each alias order costs one division.  Near ``x = 0`` the quotient is
    taken from :func:`zoh_response` instead (it is also more accurate near other
    integers ``x``, where ``sin(pi x)`` of the per-cell form cancels).
    """
    T = dt / mr.m
    res = np.arange(mr.m)
    xr = f[:, None] * T + res[None, :] / mr.m
    num = (T / np.pi) * np.exp(-1j * np.pi * xr) * np.sin(np.pi * xr)
    num = num * mr.filter_response(f[:, None] + res[None, :] / dt, dt)
    x = f[:, None] * T + orders[None, :] / mr.m
    r = np.mod(orders, mr.m)
    small = np.abs(x) < 0.25
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / x
    num_l = num if mr.m == 1 else num[:, r]
    out = np.empty(x.shape, dtype=complex)  # complex / real without a complex division
    np.multiply(num_l.real, inv, out=out.real)
    np.multiply(num_l.imag, inv, out=out.imag)
    if np.any(small):
        fi, li = np.nonzero(small)
        fl = f[fi] + orders[li] / dt
        out[small] = zoh_response(fl, T) * mr.filter_response(f[fi] + r[li] / dt, dt)
    return out


def _modal_response(plant: ModalPlant, f: np.ndarray, orders: np.ndarray, dt: float) -> np.ndarray:
    """``Pc(j 2 pi (f + l/dt))`` without the delay, (len(f), len(orders)).

    One mode at a time in real arithmetic on the (frequency x order) grid, in place:
    same values as :meth:`ModalPlant.freqresp`, without its (F, L, M) complex
    temporaries; the rigid body and undamped modes skip the imaginary part.  A cell on
    an undamped pole gives inf (reported by the caller).
    """
    om = 2.0 * np.pi * (f[:, None] + orders[None, :] / dt)
    om2 = om * om
    re = np.zeros(om.shape)
    im = np.zeros(om.shape)  # sum of r c / |den|^2; times -om at the end
    a, d = np.empty(om.shape), np.empty(om.shape)
    w, z, r = plant.arrays()
    with np.errstate(divide="ignore", invalid="ignore"):
        for wm, zm, rm in zip(w, z, r, strict=True):
            c = 2.0 * zm * wm  # den = (w^2 - om^2) + j c om
            np.subtract(wm * wm, om2, out=a)
            if c == 0.0:  # real denominator
                np.divide(rm, a, out=a)
                re += a
                continue
            np.multiply(a, a, out=d)
            d += (c * c) * om2
            np.divide(rm, d, out=d)  # d <- r / |den|^2
            a *= d
            re += a
            d *= c
            im += d
    im *= -om
    out = np.empty(om.shape, dtype=complex)
    out.real, out.imag = re, im
    return out


def _path_terms(
    plant: ModalPlant,
    mr: Multirate,
    dt: float,
    f: np.ndarray,
    orders: np.ndarray,
    band_limit_hz: float | None,
) -> np.ndarray:
    """``W Pc / Ts`` at ``f + l/dt``: shape (len(f), len(orders)).

    The delay ``e^{-j w' Td}`` at ``w' = 2 pi (f + l/dt)`` is the outer product of a
    factor per frequency and one per order.
    """
    terms = _hold_filter(mr, dt, f, orders)
    terms *= _modal_response(plant, f, orders, dt)
    scale = np.exp(-2j * np.pi * plant.delay * f) / dt
    terms *= scale[:, None]
    terms *= np.exp(-2j * np.pi * plant.delay / dt * orders)[None, :]
    if band_limit_hz is not None:
        fl = f[:, None] + orders[None, :] / dt
        terms[np.abs(fl) > band_limit_hz] = 0.0
    return terms


def _per_cell_path_terms(
    plant: ModalPlant,
    mr: Multirate,
    dt: float,
    f: np.ndarray,
    orders: np.ndarray,
    band_limit_hz: float | None,
) -> np.ndarray:
    """:func:`_path_terms` evaluated cell by cell (``ModalPlant.freqresp`` and
    :func:`zoh_response` at every ``f + l/dt``): the evaluation before issue 8, kept as
    the reference the vectorised one is tested and benchmarked against."""
    fl = f[:, None] + orders[None, :] / dt
    res = np.arange(mr.m)
    filt = mr.filter_response(f[:, None] + res[None, :] / dt, dt)
    terms = filt[:, np.mod(orders, mr.m)] * zoh_response(fl, dt / mr.m) * plant.freqresp(fl)
    if band_limit_hz is not None:
        terms = np.where(np.abs(fl) <= band_limit_hz, terms, 0.0)
    return terms / dt
