"""Regression tests for the CLI bugs of issue 7 that the bad-input table does not cover."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import typer
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

import servokit.cli
import servokit.cli._app as app_module
from servokit.cli import _discover
from servokit.cli._app import app, flag_names
from servokit.errors import (
    ServokitTypeError,
    ServokitValueError,
    check_count,
    check_memory,
    check_plot_path,
)

_discover()
runner = CliRunner()


def test_auto_n_at_the_search_limit_warns() -> None:
    # the best N sat silently at the limit (Design 1 needs N = 12 > 10)
    res = runner.invoke(app, ["seek", "--n-samples-max", "10", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["n_samples"] == 10
    assert "sits at --n-samples-max 10" in res.stderr


@pytest.mark.slow
def test_galvano_auto_n_at_the_limit_warns() -> None:
    # the case: galvano at dt 1e-5, N = 40 = the limit, 1.23 ms
    res = runner.invoke(app, ["seek", "--plant", "galvano-scanner", "--dt", "1e-5", "--json"])
    assert json.loads(res.stdout)["n_samples"] == 40
    assert "sits at --n-samples-max 40" in res.stderr


def test_plot_reports_the_real_path_written(tmp_path: Path) -> None:
    out = tmp_path / "bode.svg"
    res = runner.invoke(
        app, ["plant", "bode", "hdd-benchmark", "--n-freq", "20", "--plot", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert out.is_file() and f"wrote {out}" in res.stderr
    assert not (tmp_path / "bode.svg.png").exists()


def test_unwritable_plot_directory_is_refused(tmp_path: Path, monkeypatch) -> None:
    # PermissionError tracebacks into a read-only directory (root ignores modes: mock it)
    monkeypatch.setattr("servokit.errors.os.access", lambda *a: False)
    with pytest.raises(ServokitValueError, match="--plot .* not writable"):
        check_plot_path(tmp_path / "fig.png")


def test_warnings_before_an_error_are_dropped(monkeypatch, capsys) -> None:
    """One line on stderr: a numpy-style warning raised before the error is not shown."""
    tiny = typer.Typer()

    @tiny.command()
    def boom(fail: bool = True) -> None:
        warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
        if fail:
            raise ServokitValueError("--fail: broken on purpose")

    monkeypatch.setattr(app_module, "app", tiny)
    monkeypatch.setattr(servokit.cli, "_discover", lambda argv=None: None)
    monkeypatch.setattr("sys.argv", ["servokit"])
    with pytest.raises(SystemExit) as exc:
        app_module.main()
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.strip().splitlines() == [
        "servokit: error: --fail: broken on purpose"
    ]
    monkeypatch.setattr("sys.argv", ["servokit", "--no-fail"])
    with pytest.raises(SystemExit) as exc:
        app_module.main()
    err = capsys.readouterr().err
    assert exc.value.code == 0 and "warning: invalid value" in err  # kept on success


def test_flag_names_maps_whole_parameter_names_only() -> None:
    with pytest.raises(ServokitValueError) as exc:
        with flag_names({"n_samples": "--n-samples", "dt": "--dt"}):
            raise ServokitValueError("n_samples must be >= 1 and n_samples_max too; dt_hold, dt")
    assert str(exc.value) == "--n-samples must be >= 1 and n_samples_max too; dt_hold, --dt"
    with pytest.raises(ServokitTypeError):
        with flag_names({}):
            raise ServokitTypeError("wrong type")


def test_filesystem_errors_become_one_line(tmp_path: Path) -> None:
    with pytest.raises(ServokitValueError, match="missing"):
        with flag_names({}, prefix="--input x: "):
            open(tmp_path / "missing")  # noqa: SIM115


def test_json_has_no_nan_and_unit_suffixes() -> None:
    res = runner.invoke(
        app, ["unobservable", "magnitude", "--freq", "4000", "--dt", "25e-6", "--json"]
    )
    data = json.loads(res.stdout)
    assert "worst_sampling_phase" in data and "worst_delta_s" not in data
    assert "dt_s" in data and "dt" not in data


@settings(max_examples=200, deadline=None)
@given(
    value=st.one_of(st.integers(-10, 10**12), st.floats(allow_nan=True, allow_infinity=True)),
    lo=st.integers(0, 5),
    hi=st.integers(5, 10**9),
)
def test_check_count_accepts_exactly_the_integers_in_range(value, lo, hi) -> None:
    ok = float(value) == int(value) if np.isfinite(float(value)) else False
    ok = ok and lo <= int(value) <= hi
    if ok:
        assert check_count("--n", value, lo=lo, hi=hi) == int(value)
    else:
        with pytest.raises(ServokitValueError, match="--n"):
            check_count("--n", value, lo=lo, hi=hi)


@settings(max_examples=200, deadline=None)
@given(need=st.floats(0, 1e15, allow_nan=False), limit=st.floats(1, 1e6))
def test_check_memory_refuses_exactly_above_the_limit(need, limit) -> None:
    if need / 1e6 > limit:
        with pytest.raises(ServokitValueError, match="--max-memory-mb"):
            check_memory(need, what="--x", max_memory_mb=limit)
    else:
        check_memory(need, what="--x", max_memory_mb=limit)
