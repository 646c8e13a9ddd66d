"""Fixed-point structure: the integrator split, realisations of the remainder, L1 norms.

A realisation is described as a linear *network* ``x+ = A x + B i, o = C x + D i`` whose
inputs ``i`` are the normalised input and one rounding error per stored node and whose
outputs ``o`` are the stored nodes and the output; its impulse responses give every L1
gain the scaling and the error bound need (:mod:`servokit.export.fixed_point`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitValueError, check_finite

if TYPE_CHECKING:
    from servokit.export.fixed_point import FixedPointDesign

__all__ = ["L1_RADIUS_LIMIT", "l1_matrix", "modal_realization", "node_impulse_responses",
           "sos_network", "sos_sections", "split_integrator", "ss_network"]  # fmt: skip

_L1_TAIL = 1e-18  # an impulse response is summed until its terms fall below this
_L1_TERMS = 2_000_000  # ... or until this many terms, then refused

#: Spectral radius from which :func:`l1_matrix` refuses a network at once.  A pole at
#: radius ``1 - e`` decays by ``exp(-e N)`` over ``N`` terms: within 1e-5 of the circle the
#: 2e6 terms shrink by less than ``e^-20`` (2e-9), far from the 1e-18 tail, so summing them
#: (tens of seconds) could only end in the same refusal.  A quantised pole that rounding
#: puts on the circle reads ``1 - 3e-14`` from ``eigvals``: also caught here.
L1_RADIUS_LIMIT = 1.0 - 1e-5


def split_integrator(num: np.ndarray, den: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``C = num/den = r/(z-1) + num_r/den_r`` (``r = 0`` without a pole at ``z = 1``).

    Parameters
    ----------
    num, den : ndarray
        Polynomial coefficients in ``z`` (descending powers), ``deg num <= deg den``.

    Returns
    -------
    r : float
        Residue at ``z = 1`` (0 if there is no pole there).
    num_r, den_r : ndarray
        The remainder, with all poles strictly inside the unit circle.
    """
    num = np.trim_zeros(check_finite("controller numerator", num), "f")
    den = np.trim_zeros(check_finite("controller denominator", den), "f")
    if num.size == 0 or den.size == 0 or num.size > den.size:
        raise ServokitValueError("the controller must be proper with a nonzero denominator")
    r = 0.0
    if abs(np.polyval(den, 1.0)) <= 1e-9 * np.sum(np.abs(den)):
        den, _ = np.polydiv(den, [1.0, -1.0])
        if abs(np.polyval(den, 1.0)) <= 1e-9 * np.sum(np.abs(den)):
            raise ServokitValueError(
                "the controller has a second pole at z = 1 (on the unit circle); fixed point "
                "handles stable poles and one integrator"
            )
        r = float(np.polyval(num, 1.0) / np.polyval(den, 1.0))
        rest = np.polysub(num, r * den)
        num, _ = np.polydiv(rest, [1.0, -1.0]) if rest.size > 1 else (np.zeros(1), None)
        num = np.atleast_1d(num)
    poles = np.roots(den)
    if poles.size and np.max(np.abs(poles)) >= 1.0 - 1e-9:
        what = "a second pole at z = 1" if np.any(np.abs(poles - 1) < 1e-6) else "a pole"
        raise ServokitValueError(
            f"the controller has {what} on or outside the unit circle (|p| = "
            f"{np.max(np.abs(poles)):.9g}); fixed point handles stable poles and one integrator"
        )
    num = np.where(np.abs(num) <= 1e-13 * np.max(np.abs(num), initial=0.0), 0.0, num)
    num = np.trim_zeros(num, "f")  # leading terms that cancelled to round-off
    num = num[-den.size :] if num.size else np.zeros(1)
    return r, num, den


def l1_matrix(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``sum_k |h[k]|`` per output/input of ``x+ = A x + B u, y = C x + D u``.

    Parameters
    ----------
    a, b, c, d : ndarray
        A stable discrete state-space system.

    Returns
    -------
    ndarray (n_out, n_in)
        L1 norms of the impulse responses (summed until the terms are below 1e-18 of
        the total).
    """
    total = np.abs(d).astype(float)
    x = b.astype(float)
    # an unstable or marginal network has no L1 norm, and one within 1e-5 of the circle
    # none within the terms summed: refuse at once instead of summing two million first
    if a.size and np.max(np.abs(np.linalg.eigvals(a))) >= L1_RADIUS_LIMIT:
        raise ServokitValueError("the controller's poles are too close to the unit circle to scale")
    for k in range(_L1_TERMS):
        h = np.abs(c @ x)
        total += h
        if k >= 16 and np.max(np.abs(x), initial=0.0) <= _L1_TAIL * max(np.max(total), 1e-300):
            return total
        x = a @ x
    raise ServokitValueError("the controller's poles are too close to the unit circle to scale")


def sos_network(sections: np.ndarray, g: float) -> tuple[np.ndarray, ...]:
    """State space of a DF-I cascade: inputs ``[w0, e_1..e_K]``, outputs ``[w_1..w_K, y]``.

    ``sections[k] = [b0, b1, b2, -a1, -a2]`` (scaled values); ``e_k`` is the rounding
    error added to section k's output; states are the histories ``w_k[n-1], w_k[n-2]``.

    Parameters
    ----------
    sections : ndarray (K, 5)
        Section coefficients (values, scaled or quantised).
    g : float
        Output gain on ``w_K``.

    Returns
    -------
    A, B, C, D : ndarray
        The network.
    """
    n_sec = sections.shape[0]
    ns, ni = 2 * (n_sec + 1), n_sec + 1
    expr = np.zeros((n_sec + 1, ns + ni))  # each w_k[n] over [states, inputs]
    expr[0, ns] = 1.0
    for k in range(1, n_sec + 1):
        c = sections[k - 1]
        row = c[0] * expr[k - 1]
        for coef, idx in zip(c[1:], (2 * (k - 1), 2 * (k - 1) + 1, 2 * k, 2 * k + 1), strict=True):
            row[idx] += coef
        row[ns + k] += 1.0
        expr[k] = row
    a, b = np.zeros((ns, ns)), np.zeros((ns, ni))
    for k in range(n_sec + 1):
        a[2 * k], b[2 * k] = expr[k, :ns], expr[k, ns:]
        a[2 * k + 1, 2 * k] = 1.0
    out = np.vstack([expr[1:], g * expr[n_sec]])
    return a, b, out[:, :ns], out[:, ns:]


def ss_network(rows: np.ndarray, out: np.ndarray) -> tuple[np.ndarray, ...]:
    """Network of a state-space realisation: inputs ``[w0, e_1..e_n]``, outputs ``[x, y]``.

    Parameters
    ----------
    rows : ndarray (n, n + 1)
        State rows ``[A_i, B_i]``.
    out : ndarray (n + 1,)
        Output row ``[C, D]``.

    Returns
    -------
    A, B, C, D : ndarray
        The network (the outputs are the states and ``y``).
    """
    nx = rows.shape[0]
    a = rows[:, :nx]
    b = np.hstack([rows[:, nx:], np.eye(nx)])
    c = np.vstack([np.eye(nx), out[None, :nx]])
    d = np.zeros((nx + 1, nx + 1))
    d[nx, 0] = out[nx]
    return a, b, c, d


def sos_sections(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """Second-order sections of ``num/den`` (``scipy.signal.zpk2sos`` pairing).

    Parameters
    ----------
    num, den : ndarray
        Polynomials in ``z``.

    Returns
    -------
    ndarray (K, 6)
        Rows ``[b0 b1 b2 1 a1 a2]``.
    """
    from scipy import signal

    z, p, k = signal.tf2zpk(num, den)
    return signal.zpk2sos(z, p, k)


def modal_realization(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, ...]:
    """Real modal realisation of ``num/den``: ``2x2`` blocks ``[[s, w], [-w, s]]`` per pair.

    Built from the partial fractions ``D + sum c_i / (z - p_i)`` (distinct poles): a pair
    ``c/(z-p) + conj`` is ``A = [[Re p, Im p], [-Im p, Re p]]``, ``B = [1, 0]``,
    ``C = [2 Re c, 2 Im c]``.  Checked against ``num/den`` on the unit circle.

    Parameters
    ----------
    num, den : ndarray
        Polynomials in ``z`` of a proper, stable transfer function.

    Returns
    -------
    A, B, C, D : ndarray
        The realisation (one dummy zero state for a constant).
    """
    nx = den.size - 1
    if nx == 0:
        return np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), np.array([[num[-1] / den[0]]])
    res, poles, direct = _residue(num, den)
    a, b, c = np.zeros((nx, nx)), np.zeros((nx, 1)), np.zeros((1, nx))
    i = 0
    for rk, pk in zip(res, poles, strict=True):
        if abs(pk.imag) <= 1e-12 * max(abs(pk), 1e-300):
            a[i, i], b[i, 0], c[0, i] = pk.real, 1.0, rk.real
            i += 1
        elif pk.imag > 0:
            a[i : i + 2, i : i + 2] = [[pk.real, pk.imag], [-pk.imag, pk.real]]
            b[i, 0] = 1.0
            c[0, i : i + 2] = [2 * rk.real, 2 * rk.imag]
            i += 2
    dd = float(direct[0]) if len(direct) else 0.0
    w = np.exp(1j * np.linspace(0.01, 3.1, 64))
    modal = np.array([(c @ np.linalg.solve(z * np.eye(nx) - a, b))[0, 0] + dd for z in w])
    exact = np.polyval(num, w) / np.polyval(den, w)
    if i != nx or np.max(np.abs(modal - exact)) > 1e-7 * np.max(np.abs(exact)):
        raise ServokitValueError(
            "--realization ss: the controller's poles are repeated or too close for a modal "
            "form; use --realization sos"
        )
    return a, b, c, np.array([[dd]])


#: ``scipy.signal.residue``'s default grouping distance: closer poles count as repeated.
_RESIDUE_TOL = 1e-3


def _residue(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``scipy.signal.residue(num, den)`` without importing scipy.signal (start-up).

    For poles farther apart than its grouping distance the same arithmetic in the same
    order: roots sorted by magnitude, residue ``num(p_i) / prod_{j != i} (p_i - p_j) / den0``
    with the product built as SciPy builds it, direct term by ``np.polydiv``. Closer
    (grouped, repeated) poles go to SciPy itself.
    """
    poles = np.roots(den)
    gaps = np.abs(poles[:, None] - poles[None, :])
    np.fill_diagonal(gaps, np.inf)
    if poles.size > 1 and np.min(gaps) <= _RESIDUE_TOL:
        from scipy import signal

        return signal.residue(num, den)
    b = np.trim_zeros(np.asarray(num, dtype=float), "f")
    k = np.empty(0)
    if b.size >= den.size:
        k, b = np.polydiv(b, den)
    poles = poles[np.argsort(np.abs(poles))]
    res = np.empty(poles.size, dtype=poles.dtype)
    for i, p in enumerate(poles):
        # SciPy's factor: prefix (poles before i) times suffix (poles after i), in that order
        prefix = np.array([1])
        for q in poles[:i]:
            prefix = np.polymul(prefix, np.array([1, -q]))
        suffix = np.array([1])
        for q in poles[:i:-1]:
            suffix = np.polymul(suffix, np.array([1, -q]))
        res[i] = np.polyval(b.astype(poles.dtype), p) / np.polyval(np.polymul(prefix, suffix), p)
    return res / den[0], poles, k


def node_impulse_responses(design: FixedPointDesign, n_samples: int) -> np.ndarray:
    """Impulse responses from the normalised input to every stored node (quantised, exact).

    The worst-case input for node ``j`` over ``n_samples`` samples is
    ``sign(h[::-1, j])``: it drives the node to ``sum |h_j|``, its L1 gain.

    Parameters
    ----------
    design : FixedPointDesign
        The design.
    n_samples : int
        Length.

    Returns
    -------
    ndarray (n_samples, n_nodes)
        Node values (word value units) per unit input impulse, rounding left out.
    """
    rows = np.array([r.values() for r in design.rows])
    out = design.out_row.values()
    net = sos_network(rows, float(out[0])) if design.realization == "sos" else ss_network(rows, out)
    a, b, c, d = (m[:-1] if i >= 2 else m for i, m in enumerate(net))
    h = np.empty((n_samples, c.shape[0]))
    x = np.zeros(a.shape[0])
    u = b[:, 0]
    for k in range(n_samples):
        h[k] = c @ x + (d[:, 0] if k == 0 else 0.0)
        x = a @ x + (u if k == 0 else 0.0)
    return h
