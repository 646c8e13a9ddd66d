"""Designs the export knows: the book's HDD feedforward inputs and IVC gains, and a
user's seek input from ``servokit seek --json``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_positive

if TYPE_CHECKING:
    from servokit.feedforward import FeedforwardInput

__all__ = ["book_ivc_gain", "hdd_feedforward", "read_seek_design", "read_seek_json"]


def read_seek_json(path: str | Path, flag: str) -> tuple[np.ndarray, float]:
    """Held input samples of a ``servokit seek --json`` output (``input``, ``dt_s``).

    :func:`read_seek_design` also returns the seek distance the input was designed for.

    Parameters
    ----------
    path : str or Path
        The JSON file (``dt`` is accepted for ``dt_s``).
    flag : str
        The CLI flag that named the file, for error messages.

    Returns
    -------
    u : numpy.ndarray
        The held input ``u[k]`` [plant input unit], shape ``(N,)``.
    dt : float
        Hold period [s].
    """
    u, dt, _ = read_seek_design(path, flag)
    return u, dt


def read_seek_design(path: str | Path, flag: str) -> tuple[np.ndarray, float, float | None]:
    """:func:`read_seek_json` and the file's ``target_out`` (None when absent).

    Parameters
    ----------
    path : str or Path
        The JSON file.
    flag : str
        The CLI flag that named the file, for error messages.

    Returns
    -------
    u : numpy.ndarray
        The held input [plant input unit].
    dt : float
        Hold period [s].
    target : float or None
        The seek distance the input was designed for [output unit].
    """
    import json

    from servokit._io import number_array, read_input_text

    text = read_input_text(path, flag)  # regular file, size, encoding, nesting
    try:
        data = json.loads(text)
        raw_u, raw_dt = data["input"], data.get("dt_s", data.get("dt"))
    except (ValueError, KeyError, TypeError, AttributeError):
        raise ServokitValueError(
            f"{flag} {path}: expected the JSON of `servokit seek --json` (keys 'input' and 'dt_s')"
        ) from None
    u = number_array(raw_u, f"{flag} {path}: 'input'")
    if u.ndim != 1 or u.size == 0:
        raise ServokitValueError(f"{flag} {path}: 'input' must be a non-empty list of numbers")
    dt_arr = number_array(raw_dt, f"{flag} {path}: 'dt_s'")
    if dt_arr.ndim != 0:
        raise ServokitValueError(f"{flag} {path}: 'dt_s' must be one number [s]")
    dt = check_positive(f"{flag} {path}: 'dt_s'", float(dt_arr), "s")
    if not 1e-9 <= dt <= 1e3:  # the CLI's --dt range
        raise ServokitValueError(f"{flag} {path}: 'dt_s' {dt:g} s is outside 1e-09..1000 s")
    raw_target = data.get("target_out")
    if raw_target is None:
        return u, dt, None
    target = number_array(raw_target, f"{flag} {path}: 'target_out'")
    if target.ndim != 0 or not np.isfinite(target) or float(target) == 0.0:
        raise ServokitValueError(f"{flag} {path}: 'target_out' must be one non-zero number")
    return u, dt, float(target)


def hdd_feedforward(design: int, target: float, n_samples: int | None = None) -> FeedforwardInput:
    """The HDD benchmark feedforward of §2.4.2: Design 1 (FSC) or 2 (FFSC, Table 2.4).

    Parameters
    ----------
    design : int
        1 (minimum-jerk FSC, eqs. 2.40-2.42) or 2 (frequency-shaped FFSC, (2.74)-(2.75)).
    target : float
        Seek distance [track] (> 0).
    n_samples : int, optional
        Steps N; default the book's N for 1 track (up to 3 tracks) or 10 tracks.

    Returns
    -------
    servokit.feedforward.FeedforwardInput
        The held input, designed on the rigid-body model at Ts = 37.879 us.
    """
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark
    from servokit.seek import DESIGNS, SeekRequest, design_seek, table_2_4_weights

    if design not in (1, 2):
        raise ServokitValueError(f"--design {design}: choose 1 (FSC) or 2 (FFSC)")
    target = check_positive("--target", target, "track")
    shaped = design == 2
    book = next(d for d in DESIGNS if d.shaped == shaped and (d.tracks > 3) == (target > 3))
    n = book.N if n_samples is None else check_count("--n-samples", n_samples, lo=2, hi=100_000)
    request = SeekRequest(
        [hdd_benchmark()],
        HDD_BENCHMARK_TS,
        target,
        method="ffsc" if shaped else "fsc",
        N=n,
        band_weights=table_2_4_weights(target) if shaped else (),
    )
    return design_seek(request).ff  # type: ignore[return-value]


def book_ivc_gain(method: str, velocity_weight: float = 1.55e-7) -> tuple[np.ndarray, str]:
    """The IVC gain ``K`` of a chapter 3 book loop, loaded as ``xc[0] = K xp[0]``.

    Parameters
    ----------
    method : str
        ``"pole-zero"``: the §3.3.2 loop with the closed-loop poles 0.905 and 0.954
        cancelled (3.37); ``"jmin"``: the §3.3.1 rigid-body loop, J-min IVC (3.22) with
        ``Q = diag(1, velocity_weight, 0, 0)`` (Fig. 3.6).
    velocity_weight : float
        ``q_v`` of the J-min weight (only for ``"jmin"``).

    Returns
    -------
    K : ndarray, shape (m, n)
        Controller states per plant state.
    description : str
        What the gain is, for the export's comment.
    """
    from servokit.switching import ivc_jmin, ivc_pole_zero
    from servokit.switching.book_loops import book_loop, jmin_loop

    if method == "pole-zero":
        K = ivc_pole_zero(book_loop(), None, [0.905, 0.954])
        return K, "pole-zero IVC (3.37) of the §3.3.2 loop, poles 0.905 and 0.954 cancelled"
    if method == "jmin":
        qv = check_positive("--velocity-weight", velocity_weight)
        K = ivc_jmin(jmin_loop(), None, np.diag([1.0, qv, 0.0, 0.0]))
        return K, f"J-min IVC (3.22) of the §3.3.1 loop, Q = diag(1, {qv:g}, 0, 0)"
    raise ServokitValueError(f"--method {method!r}: choose pole-zero or jmin")
