"""``servokit unobservable ...`` and ``servokit srs`` through typer's CliRunner."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import servokit.cli
from servokit.cli._app import app
from servokit.sampled.srs import polynomial_wave, shock_response_spectrum
from servokit.sampled.unobservable import unobservable_magnitude

servokit.cli._discover()
runner = CliRunner()


def run_json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_unobservable_magnitude_json_matches_library():
    out = run_json("unobservable", "magnitude", "--freq", "20000", "--dt", "25e-6")
    assert out["worst"] == pytest.approx(1.0, abs=1e-9)  # Nyquist, §4.3.1.3
    assert out["rms"] == pytest.approx(float(unobservable_magnitude(20e3, 25e-6).rms))
    assert sum(out["histogram_percent"]) == pytest.approx(100.0)


def test_unobservable_sampling_json_book_frequencies():
    out = run_json(
        "unobservable",
        "sampling",
        "--freq",
        "40000",
        "--damping",
        "0.01",
        "--n-samples",
        "10",
        "--level",
        "0.2",
        "--fs-min",
        "5000",
        "--fs-max",
        "200000",
    )
    peaks = [iv["peak_hz"] for iv in out["intervals"]]
    np.testing.assert_allclose(peaks, [13.3e3, 20e3, 40e3, 80e3], rtol=0.01)  # Fig. 4.24


def test_unobservable_time_json_and_plot(tmp_path):
    png = tmp_path / "t.png"
    out = run_json(
        "unobservable",
        "time",
        "--freq",
        "4100",
        "--dt",
        "233e-6",
        "--level",
        "0.1",
        "--n-samples-max",
        "30",
        "--plot",
        str(png),
    )
    assert out["crossing_time_s"] == pytest.approx(3e-3, rel=0.1)  # Fig. 4.55
    assert png.stat().st_size > 5000


def test_srs_polynomial_json_and_plot(tmp_path):
    png = tmp_path / "srs.png"
    out = run_json(
        "srs",
        "--input",
        "polynomial",
        "--dt",
        "25e-6",
        "--n-samples",
        "40",
        "--fmin",
        "30000",
        "--fmax",
        "50000",
        "--n-freq",
        "201",
        "--damping",
        "0.005",
        "--freq",
        "38700",
        "--plot",
        str(png),
    )
    ref = shock_response_spectrum(polynomial_wave(40, 25e-6, 1.0), 25e-6, [38700.0], 0.005)
    assert out["at"][0]["magnitude_ratio"] == pytest.approx(ref.magnitude[0], rel=1e-9)
    assert png.stat().st_size > 5000


def test_srs_half_sine_table_and_file_input(tmp_path):
    res = runner.invoke(
        app, ["srs", "--duration", "0.5e-3", "--dt", "25e-6", "--fmax", "50000", "--n-freq", "4901"]
    )
    assert res.exit_code == 0, res.output
    assert "38" in res.stdout and "peak" in res.stdout
    f = tmp_path / "u.txt"
    np.savetxt(f, polynomial_wave(20, 25e-6, 1.0))
    out = run_json("srs", "--input", str(f), "--dt", "25e-6", "--freq", "40000", "--n-freq", "100")
    ref = shock_response_spectrum(polynomial_wave(20, 25e-6, 1.0), 25e-6, [40000.0], 0.0)
    assert out["at"][0]["magnitude_ratio"] == pytest.approx(ref.magnitude[0], rel=1e-6)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["srs", "--input", "no-such-file"], "--input"),
        (["srs", "--input", "polynomial"], "--dt"),
        (["srs", "--fmin", "10", "--fmax", "5"], "--fmin"),
        (
            ["unobservable", "magnitude", "--freq", "1000", "--dt", "1e-4", "--damping", "0.1"],
            "--n-samples",
        ),
    ],
)
def test_user_errors_exit_2(args, message, capsys, monkeypatch):
    monkeypatch.setattr("sys.argv", ["servokit", *args])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
