"""Measured frequency responses (FRFs) from files: CSV, NPZ, MATLAB .mat, python-control FRD.

:func:`read_frf` returns ``(freq_hz, response)``: strictly increasing frequencies [Hz]
and the complex response at them.  Accepted forms (names are case-insensitive):

* **CSV** (``.csv``, ``.txt``): a header row naming the columns, then one row per
  frequency; lines starting with ``#`` are comments; other columns (coherence, ...) are
  ignored.  The frequency column is ``freq_hz`` and the response one of the pairs

  - ``re``, ``im`` (real and imaginary parts),
  - ``mag_db``, ``phase_deg`` (20 log10 |P| and the phase in degrees),
  - ``mag``, ``phase_rad`` (|P| and the phase in radians).

* **NPZ** (``.npz``, ``numpy.savez``) and **MATLAB** (``.mat`` up to v7, ``scipy.io``):
  one-dimensional arrays with the same names, or a complex ``response`` array beside
  ``freq_hz``.  A python-control :class:`~control.FrequencyResponseData` saved with its own
  field names, ``numpy.savez(f, omega=frd.omega, frdata=frd.frdata)`` (frequencies in
  rad/s, ``frdata`` -- or its older name ``fresp`` -- of shape ``(1, 1, n)`` or ``(n,)``),
  is read as well.
* A :class:`control.FrequencyResponseData` object (SISO) passed instead of a path.

Bad data raises :class:`FrfFileError` with one line naming the file, the row (1-based
line of a CSV file; 1-based element of an array) and the column.  Only regular files
are read, and their size is checked against ``max_bytes`` before reading.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from servokit._io import check_data_file, decode_text
from servokit.errors import ServokitTypeError, ServokitValueError

__all__ = ["FRF_MAX_BYTES", "FRF_MAX_POINTS", "FrfFileError", "read_frf", "save_frf"]

#: Largest FRF file read unless the caller raises it [bytes] (a measured FRF is kilobytes).
FRF_MAX_BYTES = 64 * 1024 * 1024
#: Most frequency points an FRF may hold (a fine measured sweep has a few thousand; the
#: fit's Jacobian and every loop-shaping constraint grow with the count).
FRF_MAX_POINTS = 100_000

#: Response column pairs and how each becomes a complex number.
_PAIRS: tuple[tuple[str, str], ...] = (("re", "im"), ("mag_db", "phase_deg"), ("mag", "phase_rad"))
_SUFFIXES = (".csv", ".txt", ".npz", ".mat")


class FrfFileError(ServokitValueError):
    """An FRF file is missing, too large, of an unknown form or holds bad data."""


def _check_file(path: Path, max_bytes: int) -> None:
    """Refuse anything but an existing regular file of at most ``max_bytes``, before reading."""
    what = f"an FRF file ({', '.join(_SUFFIXES)})"
    check_data_file(path, max_bytes=max_bytes, what=what, error=FrfFileError)


def _split(line: str, sep: str | None) -> list[str]:
    return [c.strip() for c in (line.split(sep) if sep else line.split())]


def _csv_columns(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV file by lower-case header name; bad cells name their line."""
    try:  # UTF-8 (BOM or not) or UTF-16/32 with a BOM; binary or Latin-1 refused by name
        text = decode_text(path.read_bytes(), path, "")
    except ServokitValueError as exc:
        raise FrfFileError(str(exc).strip()) from None
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines())]
    lines = [(n, ln) for n, ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise FrfFileError(f"{path}: no header row; the first line must name the columns")
    if len(lines) - 1 > FRF_MAX_POINTS:  # counted before a cell is parsed
        raise FrfFileError(
            f"{path}: {len(lines) - 1} rows, above the {FRF_MAX_POINTS} frequency points "
            "an FRF may hold; decimate it"
        )
    head_no, head = lines[0]
    sep = next((s for s in (",", ";", "\t") if s in head), None)  # None: whitespace
    header = [h.lower() for h in _split(head, sep)]
    if len(set(header)) != len(header):
        raise FrfFileError(f"{path}: row {head_no}: a column name appears twice in the header")
    data = {h: np.empty(len(lines) - 1) for h in header}
    for k, (line_no, line) in enumerate(lines[1:]):
        row = _split(line, sep)
        if len(row) != len(header):
            raise FrfFileError(
                f"{path}: row {line_no}: {len(row)} values for {len(header)} header columns"
            )
        for h, cell in zip(header, row, strict=True):
            try:
                data[h][k] = float(cell)
            except ValueError:
                raise FrfFileError(
                    f"{path}: row {line_no}, column '{h}': {cell!r} is not a number"
                ) from None
    return {"__rows__": np.array([n for n, _ in lines[1:]], dtype=int), **data}


def _array_columns(path: Path, arrays: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """One-dimensional columns of an NPZ/MAT file by lower-case name (others skipped)."""
    out: dict[str, np.ndarray] = {}
    for key, raw in arrays.items():
        if key.startswith("__"):  # MATLAB header entries
            continue
        arr = np.asarray(raw)
        if arr.dtype.kind not in "biufc":
            continue
        key = "fresp" if key.lower() == "frdata" else key
        if key.lower() == "fresp" and arr.ndim == 3:
            if arr.shape[:2] != (1, 1):
                raise FrfFileError(f"{path}: column 'fresp' is {arr.shape}; only SISO FRDs")
            arr = arr[0, 0]
        if arr.ndim > 1 and sum(d > 1 for d in arr.shape) <= 1:
            arr = arr.ravel()  # MATLAB stores vectors as (1, n) or (n, 1)
        if arr.ndim != 1:
            raise FrfFileError(f"{path}: column '{key}' has shape {arr.shape}; give a vector")
        out[key.lower()] = arr
    out["__rows__"] = np.arange(1, 1 + max((a.size for a in out.values()), default=0))
    return out


def _load_columns(path: Path) -> dict[str, np.ndarray]:
    suffix = path.suffix.lower()
    if suffix in (".csv", ".txt"):
        return _csv_columns(path)
    if suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as npz:
                return _array_columns(path, {k: npz[k] for k in npz.files})
        except (ValueError, OSError) as exc:
            raise FrfFileError(f"{path}: not a readable .npz file ({exc})") from None
    if suffix == ".mat":
        import scipy.io

        try:
            return _array_columns(path, scipy.io.loadmat(path, squeeze_me=False))
        except NotImplementedError:
            raise FrfFileError(
                f"{path}: MATLAB v7.3 (HDF5) files are not read; save with -v7"
            ) from None
        except (ValueError, OSError, TypeError) as exc:
            raise FrfFileError(f"{path}: not a readable .mat file ({exc})") from None
    raise FrfFileError(f"{path}: unknown FRF file type; use one of {', '.join(_SUFFIXES)}")


def _column(path: Path, cols: Mapping[str, np.ndarray], name: str) -> np.ndarray:
    """A column as finite floats (complex for ``response``), naming the first bad row."""
    arr = cols[name]
    bad = ~np.isfinite(arr)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise FrfFileError(
            f"{path}: row {cols['__rows__'][i]}, column '{name}': {arr[i]} is not finite"
        )
    if np.iscomplexobj(arr) and name not in ("response", "fresp"):
        raise FrfFileError(f"{path}: column '{name}' is complex; give real values")
    return arr


def _frequencies(path: Path, cols: Mapping[str, np.ndarray]) -> np.ndarray:
    if "freq_hz" in cols:
        f = _column(path, cols, "freq_hz").astype(float)
    elif "omega" in cols:  # a python-control FRD's own field, rad/s
        f = _column(path, cols, "omega").astype(float) / (2.0 * np.pi)
    else:
        raise FrfFileError(f"{path}: no 'freq_hz' column; name the frequency column 'freq_hz' [Hz]")
    rows = cols["__rows__"]
    name = "freq_hz" if "freq_hz" in cols else "omega"
    if np.any(f < 0):
        i = int(np.argmax(f < 0))
        raise FrfFileError(f"{path}: row {rows[i]}, column '{name}': negative frequency {f[i]}")
    step = np.diff(f)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0)) + 1
        raise FrfFileError(
            f"{path}: row {rows[i]}, column '{name}': frequencies must increase strictly "
            f"({f[i - 1]:g} then {f[i]:g}); sort the rows and drop duplicates"
        )
    return f


def _response(path: Path, cols: Mapping[str, np.ndarray]) -> np.ndarray:
    found = [p for p in _PAIRS if p[0] in cols or p[1] in cols]
    found += [(k,) for k in ("response", "fresp") if k in cols]
    if len(found) != 1:
        choice = "; ".join(", ".join(p) for p in _PAIRS)
        what = "no response columns" if not found else "several response columns"
        raise FrfFileError(f"{path}: {what}; give exactly one of: {choice} (or complex response)")
    pair = found[0]
    if len(pair) == 1:
        return _column(path, cols, pair[0]).astype(complex)
    missing = [c for c in pair if c not in cols]
    if missing:
        raise FrfFileError(f"{path}: column '{missing[0]}' is missing (it pairs with the other)")
    a, b = (_column(path, cols, c).astype(float) for c in pair)
    if pair[0] == "re":
        return a + 1j * b
    if pair[0] == "mag":
        if np.any(a < 0):
            i = int(np.argmax(a < 0))
            raise FrfFileError(f"{path}: row {cols['__rows__'][i]}, column 'mag': negative")
        return a * np.exp(1j * b)
    return 10.0 ** (a / 20.0) * np.exp(1j * np.deg2rad(b))


def _from_frd(frd: Any) -> tuple[np.ndarray, np.ndarray]:
    # python-control >= 0.10.1 names the data ``frdata`` (``fresp`` is deprecated)
    data = getattr(frd, "frdata", None)
    fresp = np.asarray(frd.fresp if data is None else data)
    if fresp.ndim == 3 and fresp.shape[:2] != (1, 1):
        raise ServokitValueError(f"frd must be SISO, got {fresp.shape[0]}x{fresp.shape[1]}")
    cols = {
        "omega": np.asarray(frd.omega, dtype=float),
        "fresp": fresp.reshape(-1),
        "__rows__": np.arange(1, fresp.size + 1),
    }
    where = Path("<FrequencyResponseData>")
    return _frequencies(where, cols), _response(where, cols)


def read_frf(
    source: str | os.PathLike[str] | Any, *, max_bytes: int = FRF_MAX_BYTES
) -> tuple[np.ndarray, np.ndarray]:
    """Read a measured frequency response (format in the module docstring).

    Parameters
    ----------
    source : str, path-like or control.FrequencyResponseData
        An FRF file (``.csv``, ``.txt``, ``.npz``, ``.mat``) or a SISO python-control FRD.
    max_bytes : int
        Largest file size read [bytes]; checked before reading.

    Returns
    -------
    freq_hz : numpy.ndarray
        Frequencies [Hz], strictly increasing, shape ``(n,)``.
    response : numpy.ndarray
        Complex response at ``freq_hz``, shape ``(n,)``.

    Raises
    ------
    FrfFileError
        One line naming the file, row and column of the first bad value, or what is
        missing (no file, not a regular file, too large, no header, unknown columns).
    """
    if not isinstance(source, str | os.PathLike):
        if hasattr(source, "omega"):
            return _from_frd(source)
        raise ServokitTypeError(
            f"read_frf needs a file path or a control.FrequencyResponseData, got {type(source)}"
        )
    path = Path(source)
    _check_file(path, int(max_bytes))
    cols = _load_columns(path)
    n = {k: v.size for k, v in cols.items() if k != "__rows__"}
    if len(set(n.values())) > 1:
        raise FrfFileError(f"{path}: columns have different lengths ({n}); give equal lengths")
    freq = _frequencies(path, cols)
    resp = _response(path, cols)
    if freq.size > FRF_MAX_POINTS:  # .npz/.mat: every fit and loop evaluation scales with it
        raise FrfFileError(
            f"{path}: {freq.size} frequency points, above the {FRF_MAX_POINTS} an FRF may "
            "hold; decimate it"
        )
    if freq.size < 2:
        raise FrfFileError(f"{path}: {freq.size} frequency point(s); an FRF needs at least 2")
    return freq, resp


def save_frf(path: str | os.PathLike[str], freq_hz: np.ndarray, response: np.ndarray) -> Path:
    """Write an FRF that :func:`read_frf` reads back (CSV ``freq_hz,re,im`` or NPZ).

    Parameters
    ----------
    path : str or path-like
        Destination ending ``.csv`` or ``.npz``; written atomically.
    freq_hz : numpy.ndarray
        Frequencies [Hz], strictly increasing.
    response : numpy.ndarray
        Complex response.

    Returns
    -------
    Path
        The file written.
    """
    from servokit._io import write_atomic

    path = Path(path)
    f = np.asarray(freq_hz, dtype=float)
    r = np.asarray(response, dtype=complex)
    if f.shape != r.shape or f.ndim != 1:
        raise ServokitValueError("freq_hz and response must be vectors of the same length")
    if path.suffix.lower() == ".npz":
        buf = io.BytesIO()
        np.savez(buf, freq_hz=f, response=r)
        return write_atomic(path, buf.getvalue())
    if path.suffix.lower() != ".csv":
        raise ServokitValueError(f"{path}: save_frf writes .csv or .npz")
    rows = zip(f.tolist(), r.real.tolist(), r.imag.tolist(), strict=True)
    lines = ["freq_hz,re,im"] + [f"{a!r},{b!r},{c!r}" for a, b, c in rows]  # repr: exact
    return write_atomic(path, "\n".join(lines) + "\n")
