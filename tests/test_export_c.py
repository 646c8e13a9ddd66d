"""Firmware export: gcc compiles the generated C; the tables and step functions match Python."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from servokit.export import (
    feedforward_tables,
    quantize,
    sos_tables,
    statespace_tables,
    write_export,
)
from servokit.export.designs import hdd_feedforward
from servokit.models.controllers import controller_eq_4_69

GCC = shutil.which("gcc")
pytestmark = pytest.mark.skipif(GCC is None, reason="gcc is not installed")


def _build_and_run(tmp_path: Path, module: str, main_c: str) -> str:
    (tmp_path / "main.c").write_text(f'#include <stdio.h>\n#include "{module}.h"\n{main_c}')
    exe = tmp_path / "prog"
    subprocess.run(
        [GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O0", "-o", str(exe),
         str(tmp_path / "main.c"), str(tmp_path / f"{module}.c"), "-lm"],
        check=True, capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    return subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout


_SUM_MAIN = """
int main(void) {
    double s = 0.0;
    for (int i = 0; i < HDD_FF_U_LEN; ++i) s += (double)hdd_ff_u[i]%s;
    printf("%%.17g\\n", s);
    return 0;
}
"""


def _sequential_float_sum(values: np.ndarray) -> float:
    """The C loop's sum: float32 entries added in double, in order."""
    total = 0.0
    for v in values.astype(np.float32):
        total += float(v)
    return total


@pytest.fixture(scope="module")
def design2() -> np.ndarray:
    ff = hdd_feedforward(2, 10.0)
    assert ff.N == 17  # the book's Design 2, 10 tracks
    return ff.u


def test_design2_float_table_sums_exactly(tmp_path: Path, design2: np.ndarray) -> None:
    write_export(feedforward_tables(design2, 37.879e-6, "u"), tmp_path, "hdd_ff")
    got = float(_build_and_run(tmp_path, "hdd_ff", _SUM_MAIN % ""))
    assert got == _sequential_float_sum(design2)


@pytest.mark.parametrize("precision", ["q15", "q31"])
def test_design2_fixed_point_within_stated_error(
    tmp_path: Path, design2: np.ndarray, precision: str
) -> None:
    tables = feedforward_tables(design2, 37.879e-6, "u")
    write_export(tables, tmp_path, "hdd_ff", precision=precision)
    got = float(_build_and_run(tmp_path, "hdd_ff", _SUM_MAIN % " * HDD_FF_U_SCALE"))
    q = quantize(design2, int(precision[1:]))
    assert got == pytest.approx(float(np.sum(q.integers)) * q.scale, rel=1e-15)
    # the stated bound: each entry within half a unit, so the sum within N half units
    assert abs(got - float(np.sum(design2))) <= design2.size * q.error_bound
    assert q.max_error <= q.error_bound


_STEP_MAIN = """
#include <stdlib.h>
int main(int argc, char **argv) {
    %(t)s_state_t s;
    %(t)s_reset(&s);
    for (int i = 1; i < argc; ++i) printf("%%.17g\\n", (double)%(t)s_step(&s, atof(argv[i])));
    return 0;
}
"""


def _run_step(tmp_path: Path, module: str, prefix: str, u: np.ndarray) -> np.ndarray:
    _build_and_run(tmp_path, module, _STEP_MAIN % {"t": f"{module}_{prefix}"})
    out = subprocess.run(
        [str(tmp_path / "prog"), *[repr(float(v)) for v in u]],
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    return np.array(out.split(), dtype=float)


@pytest.mark.parametrize(
    ("realization", "precision"),
    [("ss", "double"), ("sos", "double"), ("ss", "float"), ("sos", "float")],
)
def test_controller_step_matches_python_simulation(
    tmp_path: Path, realization: str, precision: str
) -> None:
    ctrl = controller_eq_4_69()
    u = np.random.default_rng(0).standard_normal(200)
    num, den = np.asarray(ctrl.num[0][0], float), np.asarray(ctrl.den[0][0], float)
    reference = signal.lfilter(num, den, u)  # independent: direct-form difference equation
    if realization == "ss":
        tables = statespace_tables(ctrl, "ss")
    else:
        tables = sos_tables(ctrl, "sos")
        np.testing.assert_allclose(signal.sosfilt(tables[0].values, u), reference, rtol=1e-9)
    write_export(tables, tmp_path, "k", precision=precision, step=realization)
    got = _run_step(tmp_path, "k", realization, u)
    # double: rounding only; float: single-precision coefficients and arithmetic
    tol = 1e-10 if precision == "double" else 2e-4
    assert np.max(np.abs(got - reference)) <= tol * np.max(np.abs(reference))


def test_deliberately_wrong_table_is_caught(tmp_path: Path, design2: np.ndarray) -> None:
    bad = design2.copy()
    bad[5] *= 1.0 + 1e-6
    write_export(feedforward_tables(bad, 37.879e-6, "u"), tmp_path, "hdd_ff")
    got = float(_build_and_run(tmp_path, "hdd_ff", _SUM_MAIN % ""))
    assert got != _sequential_float_sum(design2)


def _clamped_model(tables: list, e: np.ndarray, u_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Python model of the clamped step: v = clip(y), x <- A x + B e + L (v - y)."""
    A, B, C, D, L = (t.values for t in tables)
    x, out, states = np.zeros(A.shape[0]), [], []
    for ek in e:
        y = float(C[0] @ x + D[0, 0] * ek)
        v = min(max(y, -u_max), u_max)
        x = A @ x + B[:, 0] * ek + L[:, 0] * (v - y)
        out.append(v)
        states.append(x)
    return np.array(out), np.array(states)


@pytest.mark.parametrize("ctrl_name", ["pi", "eq-4.69"])
def test_clamped_controller_step_matches_python_model(tmp_path: Path, ctrl_name: str) -> None:
    import control

    from servokit.export import FirmwareTable
    from servokit.simulate.saturation import antiwindup_gain

    # a PI with its integrator (pole at z = 1) winds up without the correction
    pi = control.tf([1.5, -1.4], [1.0, -1.0], 1e-4)
    ctrl = pi if ctrl_name == "pi" else controller_eq_4_69()
    tables = statespace_tables(ctrl, "ss")
    L = antiwindup_gain(tables[0].values, tables[2].values[0])
    tables.append(FirmwareTable("ss_L", L[:, None], "anti-windup"))
    rng = np.random.default_rng(1)
    e = np.concatenate([np.full(150, 2.0), -np.full(50, 2.0), rng.standard_normal(100)])
    u_max = 0.8
    write_export(tables, tmp_path, "k", precision="double", step="ss", u_max=u_max)
    got = _run_step(tmp_path, "k", "ss", e)
    want, states = _clamped_model(tables, e, u_max)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(got)) <= u_max and np.sum(np.abs(got) == u_max) > 10
    # no windup: the state levels off while clamped; without L (clamp only) it keeps growing
    bare = [*tables[:4], FirmwareTable("ss_L", 0 * L[:, None], "off")]
    _, wound = _clamped_model(bare, e, u_max)
    if ctrl_name == "pi":
        assert np.max(np.abs(states)) < 0.2 * np.max(np.abs(wound))
        assert np.ptp(states[120:150]) < 1e-3 * np.ptp(wound[120:150])
    # unsaturated (u_max above every output) the step is the linear controller
    write_export(tables, tmp_path, "k", precision="double", step="ss", u_max=1e6)
    num, den = np.asarray(ctrl.num[0][0], float), np.asarray(ctrl.den[0][0], float)
    linear = signal.lfilter(num, den, e)
    np.testing.assert_allclose(_run_step(tmp_path, "k", "ss", e), linear, rtol=1e-9, atol=1e-9)
