"""Digital feedback for :func:`servokit.simulate.simulate`, solved at the sample rate.

By superposition the plant output is ``y = y_open + y_fb``: the response to the open-loop
input (feedforward, input disturbance, initial state) plus the response to the feedback
input.  The controller sees ``e = r - yd = e0 - yd_fb`` with ``e0 = r - yd_open - dc``,
so its output ``v`` is that of the sample-rate closed loop of
:mod:`servokit.simulate.stability` driven by the known ``e0``::

    z[k+1] = A_cl z[k] + B_cl e0[k],      v[k] = C_v z[k] + D_c e0[k]

(one batched matrix-vector product per sample for all variants, or a doubling scan
for a few variants, see :mod:`servokit.simulate._scan`).  The feedback input
on the fine grid is ``v`` held over the period, or with a multirate path the filter's
sub-sample outputs ``Cf Af^i xf[k] + Cf Af^(i-1) Bf v[k]`` (``Df v[k]`` for ``i = 0``;
zero-inserted input) held over ``dt/m``, ``xf`` being the filter state inside ``z``.
The fine-grid responses then come from the open-loop kernel :func:`run_chunk`; the
feedback's one takes the modal states at the samples from ``z`` (the plant states of
the closed loop are the modal states followed by the delay line), so no second time
recursion.  The time loop does one product per sample, not a dozen small array
operations, and is skipped for the open-loop part when there is no open-loop input.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit.simulate._bank import PlantBank
from servokit.simulate._core import run_chunk
from servokit.simulate._scan import matrix_scan
from servokit.simulate.stability import ClosedLoop

__all__ = ["Loop", "run_closed"]

StateSpace = tuple[np.ndarray, np.ndarray, np.ndarray, float]


@dataclass(frozen=True)
class Loop:
    """Digital feedback ``u_fb = C(z) (r - yd)``, optionally up-sampled by ``m`` through ``F``."""

    controller: StateSpace
    reference: np.ndarray  # (K,)
    m: int = 1
    filt: StateSpace | None = None

    @property
    def multirate(self) -> tuple[int, StateSpace] | None:
        return None if self.filt is None else (self.m, self.filt)


def _controller_output(cl: ClosedLoop, e0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``v`` (V, K) and the states ``z`` (V, K, N) of the closed loops driven by ``e0``."""
    zs = matrix_scan(cl.A, e0.T[:, :, None] * cl.B[None])
    v = np.einsum("vkn,vn->vk", zs, cl.Cv) + cl.Dv * e0
    return v, zs


def _multirate_input(loop: Loop, cl: ClosedLoop, v: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """Filter outputs at the ``m`` sub-samples of every period, (V, K*m)."""
    Af, Bf, Cf, Df = loop.filt  # type: ignore[misc]
    m = loop.m
    V, K = v.shape
    xf = zs[:, :, cl.n_plant - cl.n_filter : cl.n_plant]  # (V, K, nf)
    sub = np.empty((V, K, m))
    sub[..., 0] = xf @ Cf + Df * v
    row = Cf.copy()  # Cf Af^(i-1)
    for i in range(1, m):
        gain = row @ Bf
        row = row @ Af
        sub[..., i] = xf @ row + gain * v
    return sub.reshape(V, K * m)


def run_closed(
    bank: PlantBank,
    S: int,
    K: int,
    loop: Loop,
    cl: ClosedLoop,
    u_open: np.ndarray,
    x0: np.ndarray | None = None,
    dc_samples: np.ndarray | None = None,
    fine: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-loop response of one chunk: ``y`` (V, K*S) without ``dc``, ``yd`` and ``u``.

    With ``fine=False`` ``y`` is the output at the samples (V, K) (see :func:`run_chunk`);
    ``u`` stays on the fine grid.
    """
    V, M = bank.shape
    if x0 is None and not np.any(u_open):  # nothing but the loop: no open-loop pass
        y_open, yd_open = 0.0, np.zeros((1, K)) if dc_samples is None else dc_samples
    else:
        y_open, yd_open = run_chunk(bank, S, K, u_open, x0, dc_samples, fine=fine)
    v, zs = _controller_output(cl, loop.reference[None, :] - yd_open)
    if loop.filt is None:
        u_fb = np.repeat(v, S, axis=1)
    else:
        u_fb = np.repeat(_multirate_input(loop, cl, v, zs), S // loop.m, axis=1)
    # the modal states come first in z, in the simulator's (mode, [q, dq]) order
    if S == 1:  # output on the sampling grid: the sum of the modal positions
        y_fb = yd_fb = zs[:, :, 0 : 2 * M : 2].sum(axis=-1)
    else:
        states = np.ascontiguousarray(zs[:, :, : 2 * M]).reshape(V, K, M, 2)
        y_fb, yd_fb = run_chunk(bank, S, K, u_fb, states=states, fine=fine)
    return y_open + y_fb, yd_open + yd_fb, u_open + u_fb
