"""Variation files (TOML): a plant set as a nominal plant and relative parameter ranges.

A variation file::

    kind = "variations"
    name = "stage box"            # optional
    plant = "stage.toml"          # optional nominal: catalogue name or plant file
                                  # (relative to this file); the caller may pass one instead
    gain_rel = 0.1                # optional loop-gain range: +-0.1, or [low, high]
    delay_rel = 0.2               # optional delay range, same forms
    distribution = "uniform"      # optional, or "normal" (sigma = width / 6, clipped)
    seed = 7                      # optional default Monte-Carlo seed

    [[modes]]                     # one resonance, selected by its nominal frequency
    freq_hz = 2100.0              # matched within 1 % to a mode of the nominal plant
    freq_rel = 0.05               # +-5 %, or [low, high] such as [-0.02, 0.01]
    damping_rel = 0.2             # each key optional
    residue_rel = 0.1

Every range is a relative change: a value ``x`` stands for ``[-x, +x]``, a pair
``[low, high]`` for an asymmetric range.  Each range of a ``[[modes]]`` table varies
independently of every other range (one random number each).  A ``[[modes]]`` table
whose ``freq_hz`` is a *list* of frequencies names modes that move together (one random
number for all of them), as the book's Table 2.3 rows "f4,5,6,7" and "A2,4" do.  Ranges
are numbered in file order (tables in order, within a table freq, damping, residue;
the delay range last), which fixes the Monte-Carlo stream of a given seed.

The HDD benchmark box (Table 2.3) ships as ``servokit/models/data/hdd_benchmark.variations.toml``
(:data:`HDD_BENCHMARK_VARIATIONS`).
"""

from __future__ import annotations

import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from servokit._io import check_data_file, check_nesting, decode_text
from servokit.errors import ServokitValueError
from servokit.models.modal import ModalPlant
from servokit.models.variations import Perturbation, VariationSet

__all__ = [
    "HDD_BENCHMARK_VARIATIONS",
    "VARIATION_FILE_MAX_BYTES",
    "VariationFileError",
    "read_variations",
]

#: Largest variation file read [bytes] (a box is a few hundred bytes).
VARIATION_FILE_MAX_BYTES = 1024 * 1024
#: The HDD benchmark's Table 2.3 box, shipped with the package.
HDD_BENCHMARK_VARIATIONS = resources.files("servokit.models") / "data/hdd_benchmark.variations.toml"

_TOP_KEYS = {"kind", "name", "plant", "gain_rel", "delay_rel", "distribution", "seed", "modes"}
_MODE_KEYS = {"freq_hz", "freq_rel", "damping_rel", "residue_rel"}
#: Smallest relative change each parameter admits and whether it is excluded (a frequency
#: or gain must stay > 0; a damping ratio or delay may reach 0; a residue may change sign).
_LOWEST = {
    "freq": (-1.0, True),
    "gain": (-1.0, True),
    "damping": (-1.0, False),
    "delay": (-1.0, False),
    "residue": (-math.inf, False),
}


class VariationFileError(ServokitValueError):
    """A variation file is missing or malformed."""


def _rel(path: Path, field: str, value: Any, param: str) -> tuple[float, float]:
    """A relative range from ``x`` (half-range) or ``[low, high]``, checked."""
    if isinstance(value, list):
        if len(value) != 2:
            raise VariationFileError(f"{path}: field '{field}' must be a number or [low, high]")
        low, high = (_num(path, field, v) for v in value)
    else:
        half = _num(path, field, value)
        if half < 0:
            raise VariationFileError(
                f"{path}: field '{field}' is a half-range and must be >= 0 (got {half}); "
                "give [low, high] for an asymmetric range"
            )
        low, high = -half, half
    if low > high:
        raise VariationFileError(f"{path}: field '{field}': low {low} exceeds high {high}")
    bound, strict = _LOWEST[param]
    if low < bound or (strict and low == bound):
        raise VariationFileError(
            f"{path}: field '{field}': low end {low} would make the {param} "
            f"{'zero or negative' if strict else 'negative'}; use a larger low end"
        )
    return low, high


def _num(path: Path, field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise VariationFileError(f"{path}: field '{field}' must be a finite number, got {value!r}")
    return float(value)


def _match(path: Path, where: str, freq: float, nominal: ModalPlant) -> int:
    """1-based number of the nominal mode at ``freq`` (within 1 %; exactly 0 for a rigid body)."""
    hits = [
        i
        for i, m in enumerate(nominal.modes, start=1)
        if (m.freq_hz == 0 and freq == 0) or (freq > 0 and abs(m.freq_hz - freq) <= 0.01 * freq)
    ]
    if len(hits) != 1:
        known = ", ".join(f"{m.freq_hz:g}" for m in nominal.modes)
        what = "no mode" if not hits else "several modes"
        raise VariationFileError(
            f"{path}: field '{where}': {what} of plant {nominal.name or '(given)'} within 1 % "
            f"of {freq:g} Hz; its modes are at {known} Hz"
        )
    return hits[0]


def _quoted(keys: set[str] | frozenset[str]) -> str:
    """The file's keys, quoted: they are its words, never rewritten into CLI flags."""
    return ", ".join(repr(k) for k in sorted(keys))


def _mode_ranges(path: Path, k: int, table: Any, nominal: ModalPlant) -> list[Perturbation]:
    if not isinstance(table, dict):
        raise VariationFileError(f"{path}: modes[{k}] must be a table ([[modes]])")
    extra = sorted(set(table) - _MODE_KEYS)
    if extra:
        raise VariationFileError(
            f"{path}: unknown key 'modes[{k}].{extra[0]}'; allowed keys are {_quoted(_MODE_KEYS)}"
        )
    if "freq_hz" not in table:
        raise VariationFileError(f"{path}: missing field 'modes[{k}].freq_hz' (nominal frequency)")
    raw = table["freq_hz"]
    freqs = raw if isinstance(raw, list) else [raw]
    if not freqs:
        raise VariationFileError(f"{path}: field 'modes[{k}].freq_hz' is an empty list")
    where = f"modes[{k}].freq_hz"
    modes = tuple(_match(path, where, _num(path, where, f), nominal) for f in freqs)
    if len(set(modes)) != len(modes):
        raise VariationFileError(f"{path}: field '{where}' names one mode twice")
    out = []
    for param in ("freq", "damping", "residue"):
        key = f"{param}_rel"
        if key in table:
            low, high = _rel(path, f"modes[{k}].{key}", table[key], param)
            out.append(Perturbation(param, modes, low, high))  # type: ignore[arg-type]
    return out


def _nominal(
    path: Path, data: dict[str, Any], nominal: ModalPlant | None, fallback: ModalPlant | None
) -> ModalPlant:
    if nominal is not None:
        return nominal
    if "plant" not in data and fallback is not None:
        return fallback
    if "plant" not in data:
        raise VariationFileError(
            f'{path}: no nominal plant; add plant = "NAME_OR_FILE" or pass the plant '
            "(fallback=; --plant on the command line)"
        )
    from servokit.models.catalogue import CATALOGUE
    from servokit.models.lookup import get_plant

    ref = data["plant"]
    if not isinstance(ref, str) or not ref:
        raise VariationFileError(f"{path}: field 'plant' must be a catalogue name or a file")
    if ref not in CATALOGUE and not Path(ref).is_absolute():
        ref = str(Path(path).parent / ref)  # a plant file next to the variation file
    try:
        return get_plant(ref)
    except (ServokitValueError, OSError) as exc:
        # the plant is the file's field, not a file the user typed: say where it came from
        raise VariationFileError(f"{path}: field 'plant' = {data['plant']!r}: {exc}") from None


def _check_overlap(path: Path, ranges: list[Perturbation]) -> None:
    """Refuse two ranges on the same parameter of the same mode (the box would be unclear)."""
    seen: dict[tuple[str, int], int] = {}
    for r, p in enumerate(ranges):
        for m in p.modes:
            if (p.param, m) in seen:
                raise VariationFileError(
                    f"{path}: the {p.param} of mode {m} is varied twice (ranges {seen[p.param, m]} "
                    f"and {r}); give each parameter of a mode one range"
                )
            seen[p.param, m] = r


def read_variations(
    path: str | Path | Any,
    nominal: ModalPlant | None = None,
    *,
    fallback: ModalPlant | None = None,
) -> VariationSet:
    """Read a variation file (format in the module docstring) as a :class:`VariationSet`.

    Parameters
    ----------
    path : str, Path or importlib Traversable
        The ``.toml`` file.
    nominal : ModalPlant, optional
        The nominal plant; when omitted, the file's ``plant`` (a catalogue name, or a plant
        file relative to the variation file) is loaded.
    fallback : ModalPlant, optional
        The nominal plant when neither ``nominal`` is given nor the file names one (the
        command line's ``--plant``).

    Returns
    -------
    VariationSet
        Ranges in file order (delay range last), gain range, distribution, seed and name.

    Raises
    ------
    VariationFileError
        One line naming the file and the field: missing or not a regular file, larger
        than :data:`VARIATION_FILE_MAX_BYTES`, not TOML, wrong ``kind``, unknown key, a
        frequency matching no (or several) nominal modes, or a range that would make a
        parameter invalid.
    """
    if not isinstance(path, str | Path):  # a packaged resource
        with resources.as_file(path) as real:
            return read_variations(real, nominal, fallback=fallback)
    path = Path(path)
    check_data_file(
        path,
        max_bytes=VARIATION_FILE_MAX_BYTES,
        what="a variation file (.toml)",
        error=VariationFileError,
    )
    try:
        # the shared hardened decoding: encodings named, nesting capped before parsing
        text = decode_text(path.read_bytes(), path, "")
        check_nesting(text, path, "")
    except ServokitValueError as exc:
        raise VariationFileError(str(exc).strip()) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise VariationFileError(f"{path}: not valid TOML ({exc})") from None
    if data.get("kind") != "variations":
        raise VariationFileError(f"{path}: field 'kind' must be \"variations\" in a variation file")
    extra = sorted(set(data) - _TOP_KEYS)
    if extra:
        raise VariationFileError(
            f"{path}: unknown key '{extra[0]}'; allowed keys are {_quoted(_TOP_KEYS)}"
        )
    plant = _nominal(path, data, nominal, fallback)
    tables = data.get("modes", [])
    if not isinstance(tables, list):
        raise VariationFileError(f"{path}: field 'modes' must be a list of [[modes]] tables")
    ranges = [p for k, t in enumerate(tables) for p in _mode_ranges(path, k, t, plant)]
    _check_overlap(path, ranges)
    if "delay_rel" in data:
        ranges.append(
            Perturbation("delay", (), *_rel(path, "delay_rel", data["delay_rel"], "delay"))
        )
    gain = _rel(path, "gain_rel", data["gain_rel"], "gain") if "gain_rel" in data else (0.0, 0.0)
    dist = data.get("distribution", "uniform")
    if dist not in ("uniform", "normal"):
        raise VariationFileError(f'{path}: field \'distribution\' must be "uniform" or "normal"')
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise VariationFileError(f"{path}: field 'seed' must be an integer >= 0")
    name = data.get("name", path.stem)
    return VariationSet(
        plant, tuple(ranges), gain=gain, distribution=dist, seed=seed, name=str(name)
    )
