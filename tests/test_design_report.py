"""Design report (servokit.report.design, `servokit report`): numbers against independent
computations, a self-contained page without reproduction wording."""

from __future__ import annotations

import json
import re

import control
import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.models import ModalPlant, Mode, save_controller, save_plant
from servokit.report.design import (
    FitSection,
    MarginsSection,
    SeekSection,
    SensitivitySection,
    design_report,
)

_discover()
DT = 1e-4
PLANT = ModalPlant(gain=4e6, modes=(Mode(0, 0, 1.0), Mode(2000, 0.02, -0.3)), name="small")


def _controller() -> control.TransferFunction:
    """A lead compensator with its crossover near 190 Hz, Tustin at DT."""
    wc = 2 * np.pi * 300
    k = wc**2 / 4e6
    return control.c2d(control.tf([k, k * wc / 3], [1, 3 * wc]), DT, "tustin")


def test_fit_section_errors_are_the_relative_errors():
    f = np.geomspace(50, 5000, 200)
    noise = 1 + 0.02 * np.random.default_rng(1).standard_normal(f.size)
    measured = PLANT.freqresp(f) * noise
    sec = FitSection(f, measured, PLANT)
    # the model is the plant itself: the relative error is |1 / noise - 1|
    np.testing.assert_allclose(sec.rel_error, np.abs(1 / noise - 1), rtol=1e-9)
    assert dict(sec.summary())["median |model / measured - 1|"] == (
        f"{100 * np.median(np.abs(1 / noise - 1)):.3g} %"
    )


@pytest.mark.slow
def test_margins_section_matches_python_control():
    plants = [PLANT, PLANT.replace(gain=5e6), PLANT.replace(gain=3e6)]
    sec = MarginsSection(plants, _controller())
    for p, m in zip(plants, sec.margins, strict=True):
        loop = control.ss(*control.ssdata(p.discretize(DT)), DT) * _controller()
        gm, pm, *_ = control.stability_margins(loop, method="frd")
        assert m.phase_margin_deg == pytest.approx(pm, abs=0.05)
        assert m.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=0.05)
    # the highest gain has the least gain margin
    assert sec.worst_gain_margin == 1


def test_sensitivity_section_is_one_over_one_plus_loop():
    f = np.array([10.0, 100.0, 1000.0])
    sec = SensitivitySection([PLANT], _controller(), freq_hz=f)
    loop = control.ss(*control.ssdata(PLANT.discretize(DT)), DT) * _controller()
    L = loop(np.exp(2j * np.pi * f * DT))
    np.testing.assert_allclose(sec.magnitude[0], np.abs(1 / (1 + L)), rtol=1e-6)


def test_page_is_self_contained_and_generic(tmp_path):
    secs = [SeekSection([1e-3, 2e-3, 1.5e-3], guarantee_s=2e-3)]
    out = design_report(tmp_path / "r.html", secs, title="Stage design", notes=["a note"])
    html = out.read_text()
    assert html.count("data:image/png;base64,") == 1
    assert "Stage design" in html and "a note" in html
    assert ">2</td>" in html  # worst seek time [ms] printed from the data
    assert not re.search(r"\bbook\b|reproduc", html, re.IGNORECASE)


@pytest.mark.slow
def test_cli_report_builds_every_section(tmp_path):
    save_plant(PLANT, tmp_path / "p.toml")
    save_controller(_controller(), tmp_path / "c.toml")
    f = np.geomspace(50, 5000, 100)
    r = PLANT.freqresp(f)
    np.savetxt(
        tmp_path / "frf.csv",
        np.column_stack([f, r.real, r.imag]),
        delimiter=",",
        header="freq_hz,re,im",
        comments="",
    )
    (tmp_path / "seek.json").write_text(
        json.dumps({"seek_time_s": 2e-3, "seek_times_s": [1e-3, 2e-3]})
    )
    args = ["report", "--plant", str(tmp_path / "p.toml"), "--frf", str(tmp_path / "frf.csv")]
    args += ["--controller", str(tmp_path / "c.toml"), "--seek", str(tmp_path / "seek.json")]
    args += ["--out", str(tmp_path / "r.html")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    html = (tmp_path / "r.html").read_text()
    assert html.count("data:image/png;base64,") == 4
    assert 'median |model / measured - 1|</th><td class="num">0 %' in html
