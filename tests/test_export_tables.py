"""Firmware tables: quantisation (property-based), CSV / JSON content, the export CLI."""

from __future__ import annotations

import csv
import io
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from servokit.errors import ServokitValueError
from servokit.export import (
    FirmwareTable,
    c_files,
    quantize,
    sos_tables,
    statespace_tables,
    tables_csv,
    tables_json,
)
from servokit.models.controllers import controller_eq_4_69

_values = arrays(
    np.float64,
    st.integers(1, 40),
    elements=st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False),
)


@settings(max_examples=200, deadline=None)
@given(values=_values, bits=st.sampled_from([15, 31]))
def test_quantize_within_half_unit_no_saturation_minimal_scale(
    values: np.ndarray, bits: int
) -> None:
    q = quantize(values, bits)
    assert np.all(q.integers <= 2**bits - 1) and np.all(q.integers >= -(2**bits))
    assert np.all(np.abs(values - q.integers * q.scale) <= q.error_bound * (1 + 1e-12))
    assert q.max_error <= q.error_bound
    peak = np.max(np.abs(values))
    if peak > 0:  # one bit less of range would not hold the peak
        assert peak > (2**bits - 1) * q.scale / 2 - q.error_bound


def test_quantize_hand_case() -> None:
    q = quantize(np.array([0.5, -1.0, 0.25]), 15)
    assert q.exponent == 1  # |-1.0| = 2**0 exactly: 2**15 does not fit int16, so e = 1
    assert q.scale == 2.0**-14
    assert q.integers.tolist() == [8192, -16384, 4096] and q.max_error == 0.0


def _brute_force_exponent(values: np.ndarray, bits: int) -> int:
    """Smallest e with every rint(v 2**(bits - e)) in [-(2**bits - 1), 2**bits - 1]."""
    for e in range(-60, 60):
        if np.all(np.abs(np.rint(values * 2.0 ** (bits - e))) <= 2**bits - 1):
            return e
    raise AssertionError("no exponent found")


@pytest.mark.parametrize("bits", [15, 31])
@pytest.mark.parametrize("shift", [-3, 0, 2])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_quantize_rounding_up_to_full_scale_gets_one_more_bit(
    bits: int, shift: int, sign: float
) -> None:
    # peak just below 2**shift: at e = shift it rounds to exactly 2**bits, one past the
    # largest int16 / int32, so the scale must grow by one bit (the saturation edge).
    peak = 2.0**shift * (1.0 - 2.0 ** -(bits + 2))
    values = np.array([sign * peak, 0.3 * 2.0**shift, -0.1])
    assert np.rint(peak * 2.0 ** (bits - shift)) == 2**bits  # the edge is really hit
    q = quantize(values, bits)
    assert q.exponent == shift + 1 == _brute_force_exponent(values, bits)
    dtype = np.int16 if bits == 15 else np.int32
    stored = q.integers.astype(dtype)  # what the C table holds: must not wrap around
    assert stored.astype(np.int64).tolist() == q.integers.tolist()
    assert np.all(np.abs(values - stored.astype(float) * q.scale) <= q.error_bound)


def test_table_refuses_nan_and_bad_names() -> None:
    with pytest.raises(ServokitValueError, match="finite"):
        FirmwareTable("u", np.array([1.0, np.nan]))
    with pytest.raises(ServokitValueError, match="C identifier"):
        FirmwareTable("1u", np.array([1.0]))
    with pytest.raises(ServokitValueError, match="non-empty"):
        FirmwareTable("u", np.zeros((2, 2, 2)))


def test_statespace_tables_rebuild_the_controller() -> None:
    ctrl = controller_eq_4_69()
    a, b, c, d = (t.values for t in statespace_tables(ctrl))
    z = np.exp(2j * np.pi * 500.0 * ctrl.dt)
    h = (c @ np.linalg.solve(z * np.eye(a.shape[0]) - a, b) + d)[0, 0]
    assert h == pytest.approx(complex(ctrl(z)), rel=1e-10)


def test_sos_tables_cascade_equals_transfer_function() -> None:
    ctrl = controller_eq_4_69()
    sos = sos_tables(ctrl)[0].values
    z = np.exp(2j * np.pi * 1234.0 * ctrl.dt)
    cascade = np.prod(
        [np.polyval(s[:3], z) / np.polyval(s[3:], z) for s in sos]
    )  # b, a in powers of z^-1 times z^2/z^2
    assert cascade == pytest.approx(complex(ctrl(z)), rel=1e-10)


def test_continuous_controller_refused() -> None:
    import control

    with pytest.raises(ServokitValueError, match="continuous"):
        statespace_tables(control.tf([1.0], [1.0, 1.0]))


def test_csv_and_json_hold_values_and_integers() -> None:
    t = FirmwareTable("k", np.array([[0.5, -0.25], [0.125, 1.0]]), "gain", "A/track")
    rows = list(csv.DictReader(io.StringIO(tables_csv(t, "q15"))))
    assert [(r["row"], r["col"]) for r in rows] == [("0", "0"), ("0", "1"), ("1", "0"), ("1", "1")]
    doc = tables_json([t], "m", "q15")["tables"][0]
    assert doc["shape"] == [2, 2] and doc["values"] == t.values.tolist()
    assert [int(r["q15"]) for r in rows] == np.ravel(doc["integers"]).tolist()
    assert float(rows[1]["value"]) == -0.25


def test_step_function_needs_floating_point() -> None:
    with pytest.raises(ServokitValueError, match="float or double"):
        c_files(statespace_tables(controller_eq_4_69()), "k", "q15", step="ss")


# ---- the CLI, in process (one line on stderr and exit 2 for bad input) ----
def _cli(monkeypatch, capsys, *args: str) -> tuple[int, str, str]:
    from servokit.cli import main

    monkeypatch.setattr(sys, "argv", ["servokit", "export", *args])
    try:
        main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_feedforward_json(monkeypatch, capsys, tmp_path: Path) -> None:
    code, out, err = _cli(
        monkeypatch, capsys, "feedforward", "--precision", "q15", "--out", str(tmp_path), "--json"
    )
    assert code == 0, err
    data = json.loads(out)
    assert data["files"] == [str(tmp_path / "hdd_ff.h"), str(tmp_path / "hdd_ff.c")]
    table = data["tables"][0]
    assert table["shape"] == [17] and table["max_error"] <= table["error_bound"]
    assert "#define HDD_FF_U_LEN 17" in (tmp_path / "hdd_ff.h").read_text()


def test_cli_table_from_json_file(monkeypatch, capsys, tmp_path: Path) -> None:
    src = tmp_path / "gains.json"
    src.write_text(json.dumps({"ivc_K": [[1.0, 2.0], [3.0, 4.0]]}))
    code, _, err = _cli(
        monkeypatch, capsys, "table", "--input", str(src), "--format", "csv", "--out",
        str(tmp_path),
    )  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "tables_ivc_K.csv").read_text().startswith("row,col,value\n")


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (("feedforward", "--design", "3"), "--design"),
        (("feedforward", "--precision", "q7"), "--precision"),
        (("feedforward", "--format", "xml"), "--format"),
        (("feedforward", "--target", "-1"), "--target"),
        (("feedforward", "--n-samples", "1"), "--n-samples"),
        (("controller", "--controller", "nope"), "--controller"),
        (("controller", "--controller", "eq-4.69", "--realization", "tf"), "--realization"),
        (("table", "--input", "missing.json"), "--input"),
        (("feedforward", "--name", "1bad"), "--name"),
        (("ivc", "--method", "lqr"), "--method"),
        (("ivc", "--method", "jmin", "--velocity-weight", "-1"), "--velocity-weight"),
        (("controller", "--controller", "eq-4.69", "--format", "xml"), "--format"),
    ],
)
def test_cli_bad_input_one_line_exit_2(
    monkeypatch, capsys, tmp_path: Path, args: tuple[str, ...], flag: str
) -> None:
    code, out, err = _cli(monkeypatch, capsys, *args, "--out", str(tmp_path / "fw"))
    assert code == 2
    assert not (tmp_path / "fw").exists()  # refused before writing anything
    lines = err.strip().splitlines()
    assert len(lines) == 1 and flag in lines[0]


@pytest.mark.parametrize("method", ["pole-zero", "jmin"])
def test_cli_ivc_gain_equals_the_switching_design(
    monkeypatch, capsys, tmp_path: Path, method: str
) -> None:
    from servokit.export.designs import book_ivc_gain

    code, _, err = _cli(
        monkeypatch, capsys, "ivc", "--method", method, "--format", "json", "--out",
        str(tmp_path),
    )  # fmt: skip
    assert code == 0, err
    table = json.loads((tmp_path / "ivc.json").read_text())["tables"][0]
    np.testing.assert_array_equal(table["values"], book_ivc_gain(method)[0])
    assert table["name"] == "K" and "xc[0] = K xp[0]" in table["description"]


def test_cli_out_is_a_file(monkeypatch, capsys, tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    code, _, err = _cli(monkeypatch, capsys, "feedforward", "--out", str(tmp_path / "f"))
    assert code == 2 and "--out" in err and len(err.strip().splitlines()) == 1


def test_cli_bad_table_file(monkeypatch, capsys, tmp_path: Path) -> None:
    src = tmp_path / "bad.json"
    src.write_text('{"k": [1, "x"]}')
    code, _, err = _cli(monkeypatch, capsys, "table", "--input", str(src), "--out", str(tmp_path))
    assert code == 2 and "--input" in err and len(err.strip().splitlines()) == 1


def test_cli_feedforward_seek_file_exports_the_seek_input(
    monkeypatch, capsys, tmp_path: Path
) -> None:
    """--seek: a `seek --json` input (any plant) exported exactly, float32-rounded."""
    u = np.random.default_rng(3).standard_normal(37) * 12.5
    src = tmp_path / "seek.json"
    src.write_text(json.dumps({"input": u.tolist(), "dt_s": 5e-5, "method": "robust"}))
    code, out, err = _cli(
        monkeypatch, capsys, "feedforward", "--seek", str(src), "--format", "json",
        "--out", str(tmp_path), "--name", "stage_ff", "--json",
    )  # fmt: skip
    assert code == 0, err
    assert json.loads(out)["tables"][0]["shape"] == [37]
    written = json.loads((tmp_path / "stage_ff.json").read_text())
    values = np.asarray(written["tables"][0]["values"], dtype=float)
    np.testing.assert_array_equal(values.astype(np.float32), u.astype(np.float32))
    code, _, err = _cli(monkeypatch, capsys, "feedforward", "--seek", str(src),
                        "--target", "1", "--out", str(tmp_path))  # fmt: skip
    assert code == 2 and "--target" in err and "--seek" in err
