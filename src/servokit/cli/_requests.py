"""The request layer of the ``servokit`` command line: flags -> one checked library request.

A command collects its flags in a frozen dataclass (:class:`SeekFlags`), and a builder
here turns them into the library's checked request (:class:`servokit.seek.SeekRequest`)
plus what the render layer needs.  Every check that needs a flag's name happens here;
the library's own errors name its parameters and are re-raised naming the flags through
the one table :data:`SEEK_FLAGS`.  ``seek`` (every method) and ``sweep`` (designing on the
HDD benchmark) share the builder, so a seek request is built and translated in one place.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from servokit.cli._options import (
    Output,
    flag_names,
    given_on_command_line,
    load_plant,
    load_variations,
    refuse_inapplicable,
    variation_corners,
)
from servokit.errors import (
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
)

#: SeekRequest field -> the flag of ``seek``/``sweep`` (the library's errors name fields).
#: Exact, not merged with :data:`PARAM_FLAGS`: a plant-file message keeps its words.
SEEK_FLAGS: dict[str, str] = {
    "band_weights": "--band-weight",
    "N_range": "--n-samples-max",
    "N_max": "--n-samples-max",
    "N": "--n-samples",
    "dt": "--dt",
    "target": "--target",
    "band": "--settle-band",
    "model": "--model",
    "u_max": "--u-max",
    "slew_max": "--slew-max",
    "margin": "--margin",
    "objective": "--objective",
    "method": "--method",
    "max_memory_mb": "--max-memory-mb",
}
#: fewest steps the automatic N search starts from (servokit.seek.request.SMALLEST_N)
SMALLEST_N = 3
# the book's Ts = 37.879 us with 2 ms of settling record: horizon = max(3 T, T + 2 ms)
_SETTLE_RECORD_S = 2e-3
_SUBSTEPS = 10
#: Flags of the robust design only: given with another --method they are refused
#: (--u-max applies to every method: a QP constraint for fsc/ffsc, the LP limit for robust).
_ROBUST_ONLY = {
    name: (flag, ("robust",))
    for name, flag in (
        ("margin", "--margin"), ("slew_max", "--slew-max"), ("objective", "--objective"),
    )
}  # fmt: skip


@dataclass(frozen=True)
class SeekFlags:
    """The flags of ``servokit seek`` as typed (defaults: the command's)."""

    plant: str = "hdd-benchmark"
    target: float = 1.0
    method: str = "fsc"
    n_samples: str = "auto"
    dt: float | None = None
    band_weight: list[str] | None = None
    model: str = "rigid-body"
    settle_band: float = 0.1
    delay: bool = True
    n_samples_max: int = 40
    max_memory_mb: float = 2000.0
    plot: Path | None = None
    json_out: bool = False
    u_max: float | None = None
    variations: Path | None = None
    margin: float = 0.2
    slew_max: float | None = None
    objective: str = "peak"
    n_validation: int = 2000


@dataclass(frozen=True)
class SeekJob:
    """A checked seek request and what the report needs beside it.

    Attributes
    ----------
    request : servokit.seek.SeekRequest
        The library request (plants as loaded; ``simulate_delay`` says whether their input
        delay is simulated).
    label : str
        The plant set as the user named it (``--plant``, or the ``--variations`` file).
    unit : str
        The output unit of the plot (track for the HDD benchmark).
    output : Output
        ``--plot`` / ``--json``.
    variations : str or None
        The ``--variations`` file.
    box : servokit.models.VariationSet or None
        ``--method robust --variations``: the box the design is validated over.
    n_validation : int
        ``--n-validation``.
    """

    request: Any
    label: str
    unit: str
    output: Output
    variations: str | None = None
    box: Any = field(default=None, repr=False)
    n_validation: int = 2000


def parse_band_weight(spec: str) -> tuple[float, float, float, int]:
    """One ``--band-weight F_LOW:F_HIGH:WEIGHT:N_POINTS`` [Hz:Hz:1:count].

    Parameters
    ----------
    spec : str
        The flag's value.

    Returns
    -------
    tuple
        ``(f_low_hz, f_high_hz, weight, n_points)``.
    """
    parts = spec.split(":")
    try:
        if len(parts) != 4:
            raise ValueError
        lo, hi, weight = (float(p) for p in parts[:3])
        points = int(parts[3])
    except ValueError:
        raise ServokitValueError(
            f"--band-weight {spec!r} must be F_LOW:F_HIGH:WEIGHT:N_POINTS, e.g. 6860:7070:1e10:60"
        ) from None
    check_finite("--band-weight", [lo, hi, weight])
    if not (0 <= lo < hi and weight >= 0 and points >= 1):
        raise ServokitValueError(
            f"--band-weight {spec!r}: need 0 <= F_LOW < F_HIGH [Hz], WEIGHT >= 0, N_POINTS >= 1"
        )
    return lo, hi, weight, points


def parse_n(text: str) -> int | str:
    """``--n-samples`` as an integer (``'auto'`` is handled by the caller)."""
    from servokit.errors import parse_int

    try:
        return parse_int("--n-samples", text)
    except ServokitValueError:
        raise ServokitValueError(
            f"--n-samples must be an integer or 'auto', got {text!r}"
        ) from None


def check_method(method: str, flag: str = "--method") -> str:
    """A seek design method: ``fsc``, ``ffsc`` or ``robust``."""
    if method not in ("fsc", "ffsc", "robust"):
        raise ServokitValueError(f"{flag} must be 'fsc', 'ffsc' or 'robust', got {method!r}")
    return method


def check_target(target: float) -> float:
    """``--target``: a finite, non-zero seek distance."""
    target = float(check_finite("--target", target))
    if target == 0:
        raise ServokitValueError("--target must be non-zero (a seek distance)")
    return target


def _check_flags(f: SeekFlags, inapplicable: Mapping[str, tuple[str, tuple[str, ...]]]) -> int:
    """Every flag checkable before a plant is read; returns the largest N designed."""
    check_method(f.method)
    if f.model not in ("rigid-body", "plant"):
        raise ServokitValueError(f"--model must be 'rigid-body' or 'plant', got {f.model!r}")
    refuse_inapplicable("--method", f.method, inapplicable)
    check_target(f.target)
    check_positive("--settle-band", f.settle_band)
    auto = f.n_samples == "auto"
    return check_count(
        "--n-samples-max" if auto else "--n-samples",
        f.n_samples_max if auto else parse_n(f.n_samples),
        lo=SMALLEST_N if auto else 1,
    )


def _plant_set(f: SeekFlags) -> tuple[Any, list, Any, bool, str]:
    """(nominal, plants, robust box or None, whether it is the HDD benchmark, the plant's
    label: ``--plant`` as typed, or the plant a ``--variations`` file names)."""
    from servokit.models import hdd_benchmark_variants

    is_hdd = f.plant == "hdd-benchmark"
    given = load_plant(f.plant)
    plants = hdd_benchmark_variants() if is_hdd else [given]
    if f.variations is None:
        return given, plants, None, is_hdd, f.plant
    if f.method == "robust":  # validated over the box, not a corner set
        check_count("--n-validation", f.n_validation, lo=1, hi=1_000_000)
    vset = load_variations(f.variations, fallback=given)
    nominal = vset.nominal
    plants = [nominal] if f.method == "robust" else variation_corners(vset)
    box = vset if f.method == "robust" else None
    # the file's own plant (a typed --plant agrees with it: load_variations checks)
    label = f.plant if nominal is given or given_on_command_line("plant") else nominal.name
    return nominal, plants, box, is_hdd and nominal.name == "hdd-benchmark", label


def _dt_and_bands(f: SeekFlags, is_hdd: bool) -> tuple[float, list]:
    """The hold period and the FFSC bands, with the HDD benchmark's defaults."""
    from servokit.models import HDD_BENCHMARK_TS

    bands = [parse_band_weight(b) for b in f.band_weight or []]
    dt = f.dt
    if dt is None:
        if not is_hdd:
            raise ServokitValueError("--dt is required for plants other than hdd-benchmark")
        dt = HDD_BENCHMARK_TS
    check_positive("--dt", dt, "s")
    if f.method == "ffsc" and not bands:
        if not is_hdd:
            raise ServokitValueError(
                "--method ffsc needs at least one --band-weight for this plant"
            )
        from servokit.seek import table_2_4_weights

        bands = table_2_4_weights(f.target)
    if f.method != "ffsc" and bands:
        raise ServokitValueError("--band-weight only applies to --method ffsc")
    return dt, bands


def check_seek_size(
    n_max: int, n_plants: int, n_states: int, dt: float, bands: list, max_mb: float, flag: str
) -> None:
    """Memory of the largest design (N x N Gram and band matrices) and its simulation.

    Parameters
    ----------
    n_max : int
        Largest step number designed.
    n_plants, n_states : int
        Plants simulated together and their states.
    dt : float
        Hold period [s].
    bands : list
        FFSC band weights (their points add band rows).
    max_mb : float
        ``--max-memory-mb``.
    flag : str
        The flag that set ``n_max``.
    """
    points = sum(b[3] for b in bands)
    design = (8 * n_max * n_max + 4 * points * n_max) * 8
    samples = max(3 * n_max, n_max + _SETTLE_RECORD_S / dt) * _SUBSTEPS
    sim = n_plants * samples * (n_states + 2) * 8
    check_memory(design + sim, what=f"{flag} {n_max}", max_memory_mb=max_mb)


def input_limit(request: Any, u_max: float, n_flag: str) -> tuple:
    """``|u| <= u_max`` as the QP constraint of an FSC/FFSC request, refused naming the limit
    when the largest N tried cannot meet it (more samples only make the limit easier).

    Parameters
    ----------
    request : servokit.seek.SeekRequest
        The unconstrained request.
    u_max : float
        ``--u-max``.
    n_flag : str
        The flag that bounds N.

    Returns
    -------
    tuple
        The constraint, for ``SeekRequest.limits``.
    """
    from servokit.feedforward import fsc_input
    from servokit.feedforward.constraints import InfeasibleConstraintsError, InputLimit

    limit = (InputLimit(float(u_max)),)
    n_top = request.N_max if request.N == "auto" else request.N
    design = request.design_plant or request.plants[0]
    try:
        fsc_input(design, request.dt, n_top, request.target, band_weights=list(
            request.band_weights), model=request.model, constraints=limit)  # fmt: skip
    except InfeasibleConstraintsError as exc:
        # the flags to change are named here, once: not the library's "increase N"
        binding = ", ".join(f"'{b}'" for b in exc.binding) or "the constraints together"
        raise ServokitValueError(
            f"--u-max {u_max:g}: no input of {n_top} samples ({n_flag} {n_top}) reaches the "
            f"target within |u| <= {u_max:g} (binding: {binding}); raise --u-max or {n_flag}"
        ) from None
    return limit


def seek_job(
    f: SeekFlags, inapplicable: Mapping[str, tuple[str, tuple[str, ...]]] = _ROBUST_ONLY
) -> SeekJob:
    """``servokit seek``'s flags -> the checked :class:`~servokit.seek.SeekRequest`.

    Parameters
    ----------
    f : SeekFlags
        The flags as typed.
    inapplicable : mapping
        Flags refused when typed with another method (default: the robust-only flags of
        ``seek``; ``sweep`` has its own).

    Returns
    -------
    SeekJob
        The request (every method), the robust box, the output flags.
    """
    import dataclasses

    from servokit.seek import SeekRequest

    n_top = _check_flags(f, inapplicable)
    output = Output.checked(f.plot, f.json_out)
    nominal, plants, box, is_hdd, label = _plant_set(f)
    if f.u_max is not None:
        check_positive("--u-max", f.u_max)
    dt, bands = _dt_and_bands(f, is_hdd)
    auto = f.n_samples == "auto"
    n_flag = "--n-samples-max" if auto else "--n-samples"
    check_seek_size(n_top, len(plants), nominal.order + 4, dt, bands, f.max_memory_mb, n_flag)
    robust = f.method == "robust"
    with flag_names(SEEK_FLAGS):  # the robust flags are checked by the request itself
        request = SeekRequest(
            plants, dt, f.target, f.settle_band, f.method,  # type: ignore[arg-type]
            "auto" if auto else n_top, N_max=n_top, band_weights=bands, model=f.model,
            u_max=f.u_max if robust else None, slew_max=f.slew_max if robust else None,
            margin=f.margin, objective=f.objective, simulate_delay=f.delay,
            design_plant=nominal, max_memory_mb=f.max_memory_mb,
        )  # fmt: skip
        if f.u_max is not None and not robust:  # |u| <= u_max as a QP constraint
            request = dataclasses.replace(request, limits=input_limit(request, f.u_max, n_flag))
    variations = None if f.variations is None else str(f.variations)
    unit = "track" if is_hdd else "output unit"
    return SeekJob(request, label, unit, output, variations, box, f.n_validation)
