"""Plant and controller files in TOML.

A plant file::

    name = "my-hdd"
    gain = 3.93e9          # required
    delay = 1e-5           # s, optional (default 0)
    source = "measured 2026-11"
    [[modes]]
    freq_hz = 0.0
    damping = 0.0
    residue = 1.0

A controller file (zeros/poles as numbers or ``[re, im]`` pairs; omit ``dt`` for a
continuous controller)::

    kind = "controller"
    dt = 153.5e-6
    gain = 0.872
    zeros = [0.490, 0.865, 0.908]
    poles = [0.0182, 0.409, 1.0]

or ``num = [...]`` and ``den = [...]`` instead of ``gain``/``zeros``/``poles``.
Every error names the field and says how to fix it.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from servokit._lazy import control
from servokit.errors import ServokitValueError
from servokit.models.modal import ModalPlant, Mode
from servokit.models.rational import RationalTF, rational_zpk

__all__ = [
    "PlantFileError",
    "load_plant",
    "save_plant",
    "load_controller",
    "load_controller_rational",
    "save_controller",
]

_PLANT_KEYS = {"name", "gain", "delay", "source", "modes", "kind"}
#: Highest mode frequency a plant file may give [Hz] (the CLI's --freq limit).
MAX_MODE_FREQ_HZ = 1e9
_MODE_KEYS = {"freq_hz", "damping", "residue"}
_CTRL_KEYS = {"kind", "name", "dt", "gain", "zeros", "poles", "num", "den"}


class PlantFileError(ServokitValueError):
    """A plant or controller file is malformed."""


def _read(path: Path) -> dict[str, Any]:
    path = Path(path)
    if not path.exists():
        raise PlantFileError(f"{path}: file not found; give the path of a .toml file")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise PlantFileError(f"{path}: not valid TOML ({exc})") from None


def _number(path: Path, field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise PlantFileError(f"{path}: field '{field}' must be a number, got {value!r}")
    if not math.isfinite(value):
        raise PlantFileError(f"{path}: field '{field}' must be finite, got {value!r}")
    return float(value)


def _unknown(path: Path, where: str, keys: set[str], allowed: set[str]) -> None:
    extra = sorted(keys - allowed)
    if extra:
        raise PlantFileError(
            f"{path}: unknown key '{where}{extra[0]}'; "
            # quoted: the keys are the file's words, never rewritten into CLI flags
            f"allowed keys are {', '.join(repr(k) for k in sorted(allowed))}"
        )


def load_plant(path: str | Path) -> ModalPlant:
    """Load a :class:`ModalPlant` from a TOML file, validating every field.

    Parameters
    ----------
    path : str or Path
        A plant file (format in the module docstring).

    Returns
    -------
    ModalPlant
        Gain, modes and delay [s] (default 0) of the file; ``name`` defaults to the file
        stem and ``source`` to the path.

    Raises
    ------
    PlantFileError
        If the file is missing or not TOML, has an unknown key, a missing or non-numeric
        field, no modes, or a negative delay, damping or frequency.
    """
    path = Path(path)
    data = _read(path)
    kind = data.get("kind", "plant")
    if kind in ("variations", "controller"):  # a file of servokit's, in the wrong place
        what, where = {"variations": ("variation", "--variations"),
                       "controller": ("controller", "--controller")}[kind]  # fmt: skip
        raise PlantFileError(
            f"{path}: a {what} file (kind = {kind!r}), not a plant file; give it to {where}"
        )
    _unknown(path, "", set(data), _PLANT_KEYS)
    if kind != "plant":
        raise PlantFileError(f"{path}: field 'kind' must be 'plant' for a plant file")
    if "gain" not in data:
        raise PlantFileError(f"{path}: missing field 'gain'; add e.g. 'gain = 3.93e9'")
    gain = _number(path, "gain", data["gain"])
    delay = _number(path, "delay", data.get("delay", 0.0))
    if delay < 0:
        raise PlantFileError(f"{path}: field 'delay' must be >= 0 seconds, got {delay}")
    raw_modes = data.get("modes")
    if raw_modes is not None and not isinstance(raw_modes, list):
        raise PlantFileError(f"{path}: field 'modes' must be a list of [[modes]] tables")
    if not raw_modes:
        raise PlantFileError(f"{path}: missing field 'modes'; add at least one [[modes]] table")
    modes = []
    for i, m in enumerate(raw_modes):
        if not isinstance(m, dict):
            raise PlantFileError(
                f"{path}: modes[{i}] must be a table with freq_hz, damping, residue"
            )
        _unknown(path, f"modes[{i}].", set(m), _MODE_KEYS)
        vals = {}
        for k in ("freq_hz", "damping", "residue"):
            if k not in m:
                raise PlantFileError(f"{path}: missing field 'modes[{i}].{k}'")
            vals[k] = _number(path, f"modes[{i}].{k}", m[k])
        if vals["damping"] < 0:
            raise PlantFileError(
                f"{path}: field 'modes[{i}].damping' is negative ({vals['damping']}); "
                "damping ratios must be >= 0"
            )
        if not 0 <= vals["freq_hz"] <= MAX_MODE_FREQ_HZ:
            # 1e300 Hz overflows every response evaluation (and is never meant)
            raise PlantFileError(
                f"{path}: field 'modes[{i}].freq_hz' must be in 0..{MAX_MODE_FREQ_HZ:g} Hz "
                f"(got {vals['freq_hz']:g})"
            )
        modes.append(Mode(**vals))
    try:
        return ModalPlant(
            gain=gain,
            modes=tuple(modes),
            delay=delay,
            name=str(data.get("name", path.stem)),
            source=str(data.get("source", str(path))),
        )
    except ServokitValueError as exc:  # the model's own checks (e.g. a delay above 1 s)
        raise PlantFileError(f"{path}: {exc}") from None


def save_plant(plant: ModalPlant, path: str | Path) -> None:
    """Write ``plant`` as a TOML plant file (round-trips through :func:`load_plant`).

    Parameters
    ----------
    plant : ModalPlant
        Plant to write (kind, name, gain, delay, source and one ``[[modes]]`` table per
        mode).
    path : str or Path
        File to write; overwritten if it exists.
    """
    doc = {
        "kind": "plant",
        "name": plant.name,
        "gain": plant.gain,
        "delay": plant.delay,
        "source": plant.source,
        "modes": [
            {"freq_hz": m.freq_hz, "damping": m.damping, "residue": m.residue} for m in plant.modes
        ],
    }
    Path(path).write_text(tomli_w.dumps(doc))


def _roots(path: Path, field: str, raw: Any) -> list[complex]:
    if not isinstance(raw, list):
        raise PlantFileError(f"{path}: field '{field}' must be a list of numbers or [re, im] pairs")
    out = []
    for i, r in enumerate(raw):
        if isinstance(r, list):
            if len(r) != 2:
                raise PlantFileError(f"{path}: field '{field}[{i}]' must be [re, im]")
            out.append(
                complex(_number(path, f"{field}[{i}]", r[0]), _number(path, f"{field}[{i}]", r[1]))
            )
        else:
            out.append(complex(_number(path, f"{field}[{i}]", r)))
    return out


def load_controller(path: str | Path) -> control.TransferFunction:
    """Load a controller TOML file (zeros/poles/gain or num/den; ``dt`` for discrete).

    Parameters
    ----------
    path : str or Path
        A controller file (format in the module docstring).

    Returns
    -------
    control.TransferFunction
        SISO transfer function, discrete with the file's ``dt`` [s] or continuous
        without one; from ``num``/``den`` (descending powers) when given, else from
        ``gain``, ``zeros`` and ``poles`` (:func:`~servokit.models.tf.zpk`).

    Raises
    ------
    PlantFileError
        If the file is missing or not TOML, has an unknown or malformed field, a
        ``dt <= 0``, only one of ``num``/``den``, or neither those nor ``gain``.
    """
    return load_controller_rational(path).to_control()


def _require_causal(path: Path, n_zeros: int, n_poles: int, dt: float | None) -> None:
    """Refuse a discrete controller with more zeros than poles: it needs future samples
    (no difference equation, state space or firmware realises it)."""
    if dt is not None and n_zeros > n_poles:
        raise PlantFileError(
            f"{path}: the controller is improper ({n_zeros} zeros, {n_poles} poles) and "
            "cannot run in real time; give at least as many poles as zeros"
        )


def load_controller_rational(path: str | Path) -> RationalTF:
    """:func:`load_controller` without python-control: the same file as coefficients.

    Parameters
    ----------
    path : str or Path
        A controller file (format in the module docstring).

    Returns
    -------
    RationalTF
        The controller :func:`load_controller` returns, as a
        :class:`~servokit.models.rational.RationalTF` (``.to_control()`` converts).

    Raises
    ------
    PlantFileError
        As :func:`load_controller`.
    """
    path = Path(path)
    data = _read(path)
    _unknown(path, "", set(data), _CTRL_KEYS)
    dt = data.get("dt")
    if dt is not None:
        dt = _number(path, "dt", dt)
        if dt <= 0:
            raise PlantFileError(f"{path}: field 'dt' must be > 0 seconds (omit it for continuous)")
    if "num" in data or "den" in data:
        if "num" not in data or "den" not in data:
            raise PlantFileError(f"{path}: give both 'num' and 'den'")
        for key in ("num", "den"):
            if not isinstance(data[key], list) or not data[key]:
                raise PlantFileError(f"{path}: field '{key}' must be a non-empty list of numbers")
        num = [_number(path, f"num[{i}]", v) for i, v in enumerate(data["num"])]
        den = [_number(path, f"den[{i}]", v) for i, v in enumerate(data["den"])]
        if not any(den):
            raise PlantFileError(f"{path}: field 'den' must not be all zeros")
        degree = [len(np.trim_zeros(c, "f")) - 1 for c in (num, den)]
        _require_causal(path, degree[0], degree[1], dt)
        return RationalTF(num, den, dt)
    if "gain" not in data:
        raise PlantFileError(f"{path}: missing field 'gain' (or give 'num' and 'den')")
    gain = _number(path, "gain", data["gain"])
    zeros = _roots(path, "zeros", data.get("zeros", []))
    poles = _roots(path, "poles", data.get("poles", []))
    _require_causal(path, len(zeros), len(poles), dt)
    return rational_zpk(zeros, poles, gain, dt)


def save_controller(ctrl: control.TransferFunction, path: str | Path) -> None:
    """Write a SISO transfer function as a controller TOML file (num/den form).

    Parameters
    ----------
    ctrl : control.TransferFunction
        SISO controller; its sampling period is written as ``dt`` unless it is
        continuous (``dt`` None or 0).
    path : str or Path
        File to write; overwritten if it exists.  :func:`load_controller` reads it back.
    """
    num = np.atleast_1d(np.squeeze(ctrl.num[0][0])).astype(float).tolist()
    den = np.atleast_1d(np.squeeze(ctrl.den[0][0])).astype(float).tolist()
    doc: dict[str, Any] = {"kind": "controller", "num": num, "den": den}
    if ctrl.dt not in (None, 0):
        doc["dt"] = float(ctrl.dt)
    Path(path).write_text(tomli_w.dumps(doc))
