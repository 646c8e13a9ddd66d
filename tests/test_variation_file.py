"""Variation files: the shipped HDD box reproduces the hand-coded Table 2.3 set exactly,
ranges are independent per mode, corners include the gain, bad files name the field."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import servokit as sk
from servokit.models import (
    HDD_BENCHMARK_VARIATIONS,
    ModalPlant,
    Mode,
    Perturbation,
    VariationFileError,
    VariationSet,
    read_variations,
)

#: Table 2.3 typed in from the book, independently of the shipped file.
TABLE_2_3 = (
    Perturbation("freq", (2,), -0.02, 0.01),
    Perturbation("freq", (3,), -0.05, 0.025),
    Perturbation("freq", (4, 5, 6, 7), -0.02, 0.005),
    Perturbation("residue", (2, 4), -2.0, 0.0),
    Perturbation("residue", (3,), 0.0, 0.2),
    Perturbation("damping", (5, 6, 7), -0.5, 1.0),
)
STAGE = ModalPlant(
    gain=2.0e3,
    modes=(Mode(0, 0, 1.0), Mode(2100, 0.02, -0.3), Mode(5400, 0.01, 0.2), Mode(9800, 0.03, -0.1)),
    delay=15e-6,
    name="stage",
)


def test_shipped_hdd_box_equals_table_2_3_and_changes_no_result():
    vs = sk.models.hdd_benchmark_variation_set()
    ref = VariationSet(sk.models.hdd_benchmark(), TABLE_2_3, gain=(-0.1, 0.1))
    assert vs.ranges == TABLE_2_3 and vs.gain == (-0.1, 0.1) and vs.nominal == ref.nominal
    for seed in (0, 3, 2026):
        assert vs.monte_carlo(40, seed=seed) == ref.monte_carlo(40, seed=seed)
    assert read_variations(HDD_BENCHMARK_VARIATIONS).nominal == sk.models.hdd_benchmark()
    # the 18 fixed plants are the book's rows (f up/down x zeta x residue rows)
    variants = sk.models.hdd_benchmark_variants()
    assert len(variants) == 18 and variants[0].modes == ref.nominal.modes
    assert {round(p.modes[6].damping / 0.005, 12) for p in variants} == {0.5, 1.0, 2.0}


def _write(tmp_path, text, name="v.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_per_mode_ranges_are_independent_and_matched_within_1_percent(tmp_path):
    path = _write(
        tmp_path,
        'kind = "variations"\ngain_rel = 0.1\ndelay_rel = [0.0, 0.5]\nseed = 5\n'
        + "".join(
            f"[[modes]]\nfreq_hz = {f}\nfreq_rel = 0.05\ndamping_rel = 0.2\nresidue_rel = 0.1\n"
            for f in (2110, 5380, 9800)  # 0.5 % and 0.4 % off the nominal frequencies
        ),
    )
    vs = read_variations(path, STAGE)
    assert len(vs.ranges) == 10 and vs.seed == 5
    ref = VariationSet.per_mode(STAGE, freq_rel=0.05, damping_rel=0.2, residue_rel=0.1)
    assert vs.ranges[:-1] == ref.ranges and vs.ranges[-1] == Perturbation("delay", (), 0.0, 0.5)
    assert all(len(p.modes) == 1 for p in vs.ranges[:-1])  # one range per mode and parameter
    plants = vs.monte_carlo(400)
    rel = np.array(
        [[p.modes[i].freq_hz / STAGE.modes[i].freq_hz - 1 for i in (1, 2, 3)] for p in plants]
    )
    assert np.all(np.abs(rel) <= 0.05 + 1e-12)
    corr = np.corrcoef(rel.T)[np.triu_indices(3, 1)]
    assert np.all(np.abs(corr) < 0.2)  # independent, not one draw for all modes
    delays = np.array([p.delay for p in plants]) / STAGE.delay
    assert delays.min() >= 1.0 and delays.max() <= 1.5 and delays.std() > 0.1
    gains = np.array([p.gain for p in plants]) / STAGE.gain
    assert gains.min() >= 0.9 and gains.max() <= 1.1


def test_corners_include_every_range_and_the_gain():
    vs = VariationSet.per_mode(STAGE, freq_rel=0.05, gain_rel=0.1)
    corners = vs.corners()
    assert len(corners) == 3**4  # three frequencies and the gain at nominal/low/high
    key = {
        (
            round(p.gain / STAGE.gain, 9),
            *(round(p.modes[i].freq_hz / STAGE.modes[i].freq_hz, 9) for i in (1, 2, 3)),
        )
        for p in corners
    }
    assert key == set(itertools.product((0.9, 1.0, 1.1), *[(0.95, 1.0, 1.05)] * 3))
    assert corners[0] == STAGE  # nominal first
    hdd = sk.models.hdd_benchmark_variation_set()  # ranges ending at 0 give two levels
    assert len(hdd.corners()) == 3 * 3 * 3 * 2 * 2 * 3 * 3


def test_normal_distribution_stays_in_the_box_and_centres():
    vs = VariationSet.per_mode(STAGE, damping_rel=0.3, distribution="normal")
    d = np.array([p.modes[1].damping for p in vs.monte_carlo(3000, seed=1)]) / 0.02 - 1
    assert np.all(np.abs(d) <= 0.3 + 1e-12)
    assert abs(d.mean()) < 0.01 and d.std() == pytest.approx(0.1, rel=0.08)  # sigma = width/6


def test_linked_modes_move_together(tmp_path):
    path = _write(
        tmp_path, 'kind = "variations"\n[[modes]]\nfreq_hz = [5400, 9800]\nfreq_rel = 0.05\n'
    )
    for p in read_variations(path, STAGE).monte_carlo(20):
        assert p.modes[2].freq_hz / 5400 == pytest.approx(p.modes[3].freq_hz / 9800, rel=1e-12)


def test_plant_named_in_the_file_resolves_beside_it(tmp_path):
    sk.models.save_plant(STAGE, tmp_path / "stage.toml")
    sub = tmp_path / "sub"
    sub.mkdir()
    path = _write(
        sub,
        'kind = "variations"\nplant = "../stage.toml"\n[[modes]]\nfreq_hz = 2100\n'
        "residue_rel = 0.1\n",
    )
    assert read_variations(path).nominal.modes == STAGE.modes


@pytest.mark.parametrize(
    "body, needle",
    [
        ('kind = "plant"\n', "'kind'"),
        ('kind = "variations"\nbogus = 1\n', "'bogus'"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 3000\nfreq_rel = 0.05\n', "modes[0].freq_hz"),
        ('kind = "variations"\n[[modes]]\nfreq_rel = 0.05\n', "modes[0].freq_hz"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 2100\nfreq_rel = -0.05\n', "half-range"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 2100\nfreq_rel = [0.1, -0.1]\n', "exceeds"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 2100\nfreq_rel = 1.0\n', "zero or negative"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 2100\nq_rel = 1\n', "modes[0].q_rel"),
        ('kind = "variations"\n[[modes]]\nfreq_hz = 2100\nfreq_rel = "a"\n', "modes[0].freq_rel"),
        ('kind = "variations"\ngain_rel = 1.5\n', "gain_rel"),
        ('kind = "variations"\ndistribution = "cauchy"\n', "distribution"),
        ('kind = "variations"\nseed = -1\n', "seed"),
        (
            'kind = "variations"\n[[modes]]\nfreq_hz = 2100\nfreq_rel = 0.1\n[[modes]]\n'
            "freq_hz = [2100, 5400]\nfreq_rel = 0.1\n",
            "varied twice",
        ),
        ("kind = [", "not valid TOML"),
    ],
)
def test_bad_files_name_file_and_field(tmp_path, body, needle):
    path = _write(tmp_path, body)
    with pytest.raises(VariationFileError) as err:
        read_variations(path, STAGE)
    assert needle in str(err.value) and str(path) in str(err.value)


def test_missing_plant_and_non_regular_file(tmp_path):
    with pytest.raises(VariationFileError, match="no nominal plant"):
        read_variations(_write(tmp_path, 'kind = "variations"\n'))
    with pytest.raises(VariationFileError, match="regular file"):
        read_variations(tmp_path)
