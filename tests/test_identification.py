"""Identification above Nyquist (5.10)-(5.11) against the true plant response."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.errors import ServokitValueError
from servokit.models import (
    ModalPlant,
    Mode,
    pzt_active_suspension,
    vcm_controller_table_5_2,
    vcm_dual_stage,
)
from servokit.sampled.identification import aliased_frequency, identify_above_nyquist

FS = 30000.0


@settings(max_examples=50, deadline=None)
@given(f=st.floats(1.0, 2e5), fs=st.floats(100.0, 1e5))
def test_alias_is_in_the_first_band_and_differs_by_whole_sampling_frequencies(f, fs):
    a = float(aliased_frequency(np.array([f]), 1 / fs)[0])
    assert 0 <= a < fs
    n = (f - a) / fs
    assert n == pytest.approx(round(n), abs=1e-6)


def test_vcm_in_the_loop_is_recovered_below_and_above_nyquist():
    plant = vcm_dual_stage()
    f = np.array([450.0, 6400.0, 14950.0, 15000.0, 21350.0, 30000.0, 38400.0, 44950.0])
    res = identify_above_nyquist(plant, vcm_controller_table_5_2(), f, n_measure=600)
    assert list(res.excluded_hz) == [15000.0, 30000.0]
    db, deg = res.errors(plant.freqresp(res.freq_hz))
    assert np.max(np.abs(db)) < 0.05 and np.max(np.abs(deg)) < 0.5
    # Sd is the discrete loop's sensitivity 1/(1 + G C) at the alias, not (5.9)'s T

    loop = plant.discretize(1 / FS) * vcm_controller_table_5_2()
    z = np.exp(2j * np.pi * res.aliased_hz / FS)
    sd = 1 / (1 + np.array([complex(loop(x)) for x in z]))
    np.testing.assert_allclose(res.sd, sd, rtol=1e-3)


def test_pzt_outside_the_vcm_loop_is_recovered():
    plant = pzt_active_suspension()
    f = np.array([2500.0, 9100.0, 18400.0, 36000.0])
    res = identify_above_nyquist(
        plant, vcm_controller_table_5_2(), f, n_measure=600, loop_plant=vcm_dual_stage()
    )
    db, deg = res.errors(plant.freqresp(res.freq_hz))
    assert np.max(np.abs(db)) < 0.05 and np.max(np.abs(deg)) < 0.5


def test_single_mode_hand_case():
    # the VCM's low-frequency mode plus one mode at 21 kHz, above the 15 kHz Nyquist frequency
    plant = ModalPlant(gain=1.9e4, modes=(Mode(19.5, 0.2, 7500.0), Mode(21000.0, 0.02, -3000.0)))
    ctrl = vcm_controller_table_5_2()
    res = identify_above_nyquist(plant, ctrl, np.array([1000.0, 21000.0]), n_measure=30)
    np.testing.assert_allclose(res.response, plant.freqresp(res.freq_hz), rtol=5e-3)


def test_bad_arguments():
    ctrl = vcm_controller_table_5_2()
    with pytest.raises(ServokitValueError):
        identify_above_nyquist(vcm_dual_stage(), ctrl, np.array([-5.0]))
    with pytest.raises(ServokitValueError):
        identify_above_nyquist(vcm_dual_stage(), ctrl, np.array([200e3]))  # above 12 fs / 2
    with pytest.raises(ServokitValueError, match="MB"):
        identify_above_nyquist(vcm_dual_stage(), ctrl, np.arange(50, 6e4, 50), max_memory_mb=1)


@pytest.mark.slow
def test_book_grid_1200_frequencies_within_half_db_and_3_deg():
    plant = vcm_dual_stage()
    res = identify_above_nyquist(plant, vcm_controller_table_5_2(), np.arange(50, 60001, 50.0))
    band = res.freq_hz <= 45000
    db, deg = res.errors(plant.freqresp(res.freq_hz))
    assert res.freq_hz.size == 1196
    assert np.max(np.abs(db[band])) < 0.5 and np.max(np.abs(deg[band])) < 3.0


_discover()
runner = CliRunner()


def test_cli_identify_json():
    out = runner.invoke(
        app,
        [
            "identify",
            "--plant",
            "vcm-dual-stage",
            "--controller",
            "table-5.2",
            "--fs",
            "30e3",
            "--freq-step",
            "7000",
            "--json",
        ],
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["fs_hz"] == 30000.0 and len(data["freq_hz"]) == 9
    assert data["max_error_db"] < 0.5  # up to 56 kHz


@pytest.mark.parametrize(
    "args, flag",
    [
        (["--fs", "20e3"], "--fs"),
        (["--fmin", "0"], "--fmin"),
        (["--fmax", "300e3"], "--fmin/--fmax"),
        (["--freq-step", "1", "--max-memory-mb", "1"], "--max-memory-mb"),
    ],
)
def test_cli_identify_bad_input(args, flag, monkeypatch, capsys):
    import sys

    from servokit.cli import main

    argv = ["servokit", "identify", "--plant", "vcm-dual-stage", "--controller", "table-5.2"]
    monkeypatch.setattr(sys, "argv", argv + args)
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and flag in lines[0]


@pytest.mark.slow
def test_identification_vcm_case(tmp_path):
    from servokit.cases.identification import identification_vcm_case

    r = identification_vcm_case(tmp_path)
    assert r.name == "identification-vcm" and all(c.ok for c in r.comparisons)
    assert list(r.extra["excluded_hz"]) == [15000.0, 30000.0, 45000.0, 60000.0]
    assert len(r.figures) == 2 and all(p.exists() for p in r.figures)


@pytest.mark.slow
def test_identification_pzt_case(tmp_path):
    from servokit.cases.identification import identification_pzt_case

    r = identification_pzt_case(tmp_path)
    assert r.name == "identification-pzt" and all(c.ok for c in r.comparisons)


def test_chapter5_cases_are_registered():
    from servokit.cases import registry

    names = set(registry())
    assert {
        "resonance-filters",
        "peak-filter-12khz",
        "ltv-peak-filter-locus",
        "ltv-peak-filter-transient",
        "identification-vcm",
        "identification-pzt",
    } <= names


@settings(max_examples=40, deadline=None)
@given(
    hold=st.integers(1, 13),
    substeps=st.integers(1, 13),
    n=st.integers(1, 40),
    f=st.lists(st.floats(1.0, 2e5), min_size=1, max_size=4),
)
def test_held_sinusoids_equal_cos_of_the_held_time(hold, substeps, n, f):
    from servokit.sampled.identification import _held_sinusoids

    dt = 1 / 30e3
    freq = np.asarray(f)
    k = np.arange(n * substeps)
    # the direct form: the time of every fine step rounded down to its hold start
    t_held = dt / substeps * (k // hold * hold)
    direct = np.cos(2 * np.pi * freq[:, None] * t_held[None, :])
    np.testing.assert_array_equal(_held_sinusoids(freq, dt, substeps, hold, n), direct)
