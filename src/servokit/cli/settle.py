"""``servokit settle``: train, evaluate and apply the SVM settling judge (book §6.2)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlotOpt,
    SeedOpt,
    console,
    emit_json,
    example,
    plot_target,
    progress,
    started,
    sub_app,
    wrote,
)
from servokit.cli._options import old_name, renamed
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitError,
    ServokitValueError,
    check_count,
    check_finite,
    check_input_file,
    check_memory,
    check_positive,
)

settle_app = sub_app("settle", "SVM settling judgement of track seeks (§6.2).")

JudgeOpt = Annotated[
    Path, typer.Option("--judge", help="judge file written by 'settle train' (.skops)")
]
BandOpt = Annotated[
    float, typer.Option("--settle-band", help="allowable tracking-error bound [track]")
]


def _check_judge_file(path: Path) -> Path:
    """The cheap checks of ``--judge`` (no scikit-learn yet): an existing regular file
    holding a zip archive, as skops writes; every error names the flag."""
    import zipfile

    from servokit._io import check_regular_file

    if path.is_dir():
        raise ServokitValueError(f"--judge {path} is a directory; give a .skops judge file")
    if not os.path.lexists(path):
        raise ServokitValueError(
            f"--judge {path} does not exist; run 'servokit settle train' first"
        )
    check_regular_file(path, "--judge")
    if not zipfile.is_zipfile(path):
        raise ServokitValueError(f"--judge {path}: not a servokit settling-judge file")
    return path


def _load(path: Path):
    """The judge file named by ``--judge`` (checked by :func:`_check_judge_file`); every
    error names the flag."""
    from servokit.learn import SettlingJudge

    try:
        return SettlingJudge.load(path)
    except ServokitError as exc:
        raise ServokitValueError(f"--judge {path}: {exc}") from None
    except Exception as exc:  # a foreign file skops cannot read: one line naming the flag
        raise ServokitValueError(
            f"--judge {path}: not a servokit settling-judge file ({type(exc).__name__})"
        ) from None


def _check_out_file(out: Path, flag: str = "--judge") -> Path:
    """Refuse an unusable judge file to write before training (nothing is written)."""
    from servokit.errors import path_errors

    with path_errors(flag, out):
        return _check_out_path(out, flag)


def _check_out_path(out: Path, flag: str) -> Path:
    if str(out).endswith(("/", "\\")) or out.is_dir():
        raise ServokitValueError(f"{flag} {out} is a directory; give a file name ending .skops")
    if out.suffix != ".skops":
        raise ServokitValueError(f"{flag} {out}: use a file name ending .skops")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise ServokitValueError(
            f"{flag} {out}: directory {parent} does not exist; create it first"
        )
    if os.path.lexists(out) and not out.is_file():
        raise ServokitValueError(f"{flag} {out} is not a regular file (a pipe or device)")
    target = out if out.exists() else parent
    if not os.access(target, os.W_OK):
        raise ServokitValueError(f"{flag} {out}: {target} is not writable; choose another path")
    return out


def _check_seed(seed: int) -> int:
    if seed < 0:
        raise ServokitValueError(f"--seed must be >= 0 (got {seed})")
    return seed


#: Samples kept per simulated seek: the longest input (135 samples) and the default record
#: of :func:`servokit.learn.simulate_seeks` after it (3000 samples + 1), six states and the
#: output each (8 bytes)
_BYTES_PER_SEEK = (135 + 3001) * 7 * 8


def _check_seek_memory(n_seeks: int, what: str, max_memory_mb: float) -> None:
    """Refuse a set of simulated seeks estimated above ``--max-memory-mb`` (all are kept)."""
    check_memory(n_seeks * _BYTES_PER_SEEK, what=what, max_memory_mb=max_memory_mb)


def _simulate(seeks: list[tuple[float, int]], what: str):
    from threadpoolctl import threadpool_limits

    from servokit.learn import iter_seeks

    # one discretisation and one set of free-run powers for all seeks (a list of
    # one-seek calls redid both per seek); one BLAS thread: on 6 x 6 products and the
    # FSC designs' small expm, OpenBLAS threads spin instead of working (100 validation
    # seeks: 1.5 s with two threads on the shared 2-core machine, 0.45 s with one)
    with progress(len(seeks), what) as advance, threadpool_limits(limits=1):
        out = []
        for r in iter_seeks(seeks):
            out.append(r)
            advance()
    return out


@settle_app.command(
    "train",
    epilog=example(
        "servokit settle train --judge judge.skops", "add --cv to choose C and the offset"
    ),
)
def train_cmd(
    out: Path = typer.Option(
        Path("judge.skops"), "--judge", help="judge file to write (.skops)", metavar="FILE"
    ),
    out_old: old_name("--out", Path) = None,
    n_distances: int = typer.Option(10, "--n-distances", help="distances 10-900 track", min=2),
    n_lengths: int = typer.Option(18, "--n-lengths", help="FSC lengths 24-130 samples", min=2),
    settle_band: BandOpt = 0.03,
    c: float = typer.Option(10.0, "--svm-c", help="SVM soft-margin weight C [1]"),
    c_old: old_name("--c") = None,
    coef0: float = typer.Option(0.5, "--coef0", help="polynomial kernel offset"),
    class1_weight: float = typer.Option(
        1.0, "--class1-weight", help="weight of class-1 errors (> 1: judge later, safer)"
    ),
    cv: bool = typer.Option(False, "--cv", help="choose C and the offset by 3-fold CV (slower)"),
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    json_out: JsonOpt = False,
) -> None:
    """Train the judge on FSC seeks of plant (6.7).  JSON: n_states, n_class1, n_class2, c,
    coef0, cv_scores, judge."""
    from servokit.learn import training_set

    # every flag and the output path are checked before the seeks are simulated
    given = renamed(out, out_old, new_flag="--judge", old_flag="--out", default=Path("judge.skops"))
    out = _check_out_file(given, "--out" if out_old is not None else "--judge")
    c = renamed(c, c_old, new_flag="--svm-c", old_flag="--c", default=10.0)
    judge, seeks = _train_request(
        n_distances, n_lengths, settle_band, c, "--c" if c_old is not None else "--svm-c",
        coef0, class1_weight,
    )  # fmt: skip
    _check_seek_memory(
        len(seeks), f"--n-distances {n_distances} x --n-lengths {n_lengths}", max_memory_mb
    )
    fit = "3-fold CV over 9 (C, offset) pairs" if cv else "one fit"
    started("settle train", f"simulating {len(seeks)} seeks, then the SVM ({fit}) -> {out}")
    data = training_set(_simulate(seeks, "simulating seeks"), bound=judge.bound)
    judge = judge.tune(data.X, data.labels) if cv else judge.fit(data.X, data.labels)
    judge.save(out)
    wrote(out)
    _render_train(judge, data, len(seeks), out, json_out)


#: largest |--coef0|: the degree-4 kernel of standardised features stays far from overflow
_MAX_COEF0 = 1e6


def _train_request(
    n_distances: int, n_lengths: int, settle_band: float, c: float, c_flag: str,
    coef0: float, class1_weight: float,
) -> tuple[Any, list]:  # fmt: skip
    """The checked training flags: an unfitted judge and the training seeks (6.7)."""
    from servokit.learn import SettlingJudge, training_seeks

    n_distances = check_count("--n-distances", n_distances, lo=2, hi=1000)
    n_lengths = check_count("--n-lengths", n_lengths, lo=2, hi=107)
    settle_band = check_positive("--settle-band", settle_band, "track")
    if not 1e-3 <= settle_band <= 10:  # the labels need seeks both in and out of the band
        raise ServokitValueError(
            f"--settle-band must be 0.001..10 track (got {settle_band:g}); the book uses 0.1"
        )
    c = check_positive(c_flag, c)
    coef0 = float(check_finite("--coef0", coef0))
    if abs(coef0) > _MAX_COEF0:  # (g <x, x'> + coef0)^4 of standardised features overflows
        raise ServokitValueError(
            f"--coef0 must be within -{_MAX_COEF0:g}..{_MAX_COEF0:g} (got {coef0:g}); the "
            "features are standardised, the book's grid is 0.5..2"
        )
    class1_weight = check_positive("--class1-weight", class1_weight)
    judge = SettlingJudge(bound=settle_band, C=c, coef0=coef0, class1_weight=class1_weight)
    return judge, training_seeks(n_distances, n_lengths)


def _render_train(judge: Any, data: Any, n_seeks: int, out: Path, json_out: bool) -> None:
    """Print or emit the trained judge's summary."""
    n1, n2 = data.counts
    res = {
        "n_states": len(data.X),
        "n_class1": n1,
        "n_class2": n2,
        "c": judge.C,
        "coef0": judge.coef0,
        "judge": str(out),
        "cv_scores": [
            {"c": k[0], "coef0": k[1], "balanced_accuracy": v} for k, v in judge.cv_scores_.items()
        ],
    }
    if json_out:
        emit_json(res)
        return
    console.print(
        f"{n_seeks} seeks, {len(data.X)} states (class 1: {n1}, class 2: {n2}); "
        f"C = {judge.C:g}, offset = {judge.coef0:g}"
    )


@settle_app.command(
    "evaluate",
    epilog=example("servokit settle evaluate --judge judge.skops --plot hist.png"),
)
def evaluate_cmd(
    judge_path: JudgeOpt = Path("judge.skops"),
    n_seeks: int = typer.Option(100, "--n-seeks", help="validation seeks", min=1, max=100_000),
    seed: SeedOpt = 1,
    level: float = typer.Option(-0.8, "--level", help="safety decision level (book: -0.8)"),
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Validate on random seeks of 5-1000 tracks, 20-135 samples (Figs. 6.10-6.12).

    JSON: methods[] with method, failures, never_judged, mean_delay_samples, delays_samples.
    """
    from servokit.learn import evaluate_judgements, validation_seeks

    plot = plot_target(plot)
    n_seeks = check_count("--n-seeks", n_seeks, lo=1, hi=100_000)
    seed = _check_seed(seed)
    level = float(check_finite("--level", level))
    _check_seek_memory(n_seeks, f"--n-seeks {n_seeks}", max_memory_mb)
    _check_judge_file(judge_path)
    started(
        "settle evaluate",
        f"loading {judge_path}, simulating {n_seeks} seeks, judging them 3 ways",
    )
    judge = _load(judge_path)
    responses = _simulate(validation_seeks(n_seeks, seed), "simulating seeks")
    stats = evaluate_judgements(responses, judge, levels=(0.0, level))
    if plot is not None:
        from servokit.learn import judgement_plot

        wrote(
            judgement_plot(
                [stats[1], stats[0], stats[2]],
                plot,
                figures=["Fig. 6.10", "Fig. 6.11", "Fig. 6.12"],
            )
        )
    if json_out:
        emit_json({"methods": [s.to_dict() for s in stats]})
        return
    for s in stats:
        console.print(
            f"{s.method:>28}: failures {s.failures:3d}, mean N_judge - N0 "
            + (f"{s.mean_delay:.2f} samples" if np.isfinite(s.mean_delay) else _NO_MEAN)
        )


#: The mean delay when no seek was judged without a failure (never "nan samples").
_NO_MEAN = "n/a (no seek judged without a failure)"


@settle_app.command(
    "judge",
    epilog=example(
        "servokit settle judge --judge judge.skops --target 300 --n-samples 50",
        "servokit settle judge --judge judge.skops --record states.csv",
    ),
)
def judge_cmd(
    judge_path: JudgeOpt = Path("judge.skops"),
    target: float = typer.Option(100.0, "--target", help="seek distance [track]"),
    n_samples: int = typer.Option(50, "--n-samples", help="FSC input length [samples]", min=4),
    record: Path | None = typer.Option(
        None,
        "--record",
        help="CSV of recorded states: one row per sample, the six states "
        "then the output [track], target at 0 (replaces the simulated seek)",
    ),
    level: float = typer.Option(0.0, "--level", help="decision level (0, or -0.8 safe side)"),
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    json_out: JsonOpt = False,
) -> None:
    """Judge one seek (simulated, or a recorded state sequence).

    JSON: n_judge, n0, n_conventional (samples; null = does not settle) and reason (why a
    count is null, else null).
    """
    if float(check_finite("--target", target)) == 0:
        raise ServokitValueError("--target must be non-zero [track] (got 0)")
    n_samples = check_count("--n-samples", n_samples, lo=4, hi=100_000)
    if record is None:  # the FSC design holds a few N x N matrices
        check_memory(
            4 * 8.0 * n_samples**2, what=f"--n-samples {n_samples}", max_memory_mb=max_memory_mb
        )
    level = float(check_finite("--level", level))
    recorded = None if record is None else _read_record(check_input_file(record, "--record"))
    _check_judge_file(judge_path)
    what = f"the states of {record}" if record is not None else f"a {target:g}-track seek"
    started("settle judge", f"loading {judge_path}, judging {what}")
    judge = _load(judge_path)
    if recorded is not None:
        states, output, start = *recorded, 0
    else:
        (r,) = _simulate([(target, n_samples)], "simulating")
        states, output, start = r.states, r.output, 0
    res = _judgement(judge, states, output, level, start)
    if json_out:
        emit_json(res)
        return
    if res["reason"]:
        console.print(f"does not settle: {res['reason']}")
    console.print(
        f"SVM judges settled at sample {_or_never(res['n_judge'])}, 5-in-a-row at "
        f"{_or_never(res['n_conventional'])}; actual settling N0 = {_or_never(res['n0'])}"
    )


def _read_record(record: Path) -> tuple[np.ndarray, np.ndarray]:
    """``--record``: the six states and the output of each row of a numeric CSV."""
    try:
        table = np.loadtxt(record, delimiter=",", ndmin=2)
    except (OSError, ValueError) as exc:
        raise ServokitValueError(f"--record {record}: cannot read a numeric CSV ({exc})") from None
    if table.shape[1] != 7:
        raise ServokitValueError(f"--record {record}: need 7 columns (6 states, output)")
    bad = np.flatnonzero(~np.all(np.isfinite(table), axis=1))
    if bad.size:
        raise ServokitValueError(
            f"--record {record}: row {bad[0] + 1} holds NaN or inf; give finite samples"
        )
    return table[:, :6], table[:, 6]


def _or_never(n: int | None) -> str:
    return "never" if n is None else str(n)


def _judgement(judge: Any, states: Any, output: Any, level: float, start: int) -> dict:
    """The three settling counts; a count that never happens is None with a reason (a
    sentinel -1 would read as a sample index)."""
    from servokit.learn import conventional_judgement, settled_index

    def count(n: int) -> int | None:
        return None if n is None or n < 0 else int(n)

    settled = abs(output[-1]) <= judge.bound
    res = {
        "n_judge": count(judge.judge(states, output, level, start=start)),
        "n_conventional": count(conventional_judgement(output, judge.bound, start=start)),
        "n0": count(settled_index(output, judge.bound)) if settled else None,
    }
    res["reason"] = (
        None
        if res["n0"] is not None
        else f"the output ends {abs(output[-1]):.3g} from the target, outside the band "
        f"+-{judge.bound:g}"
    )
    return res
