"""JSON keys of the switching, unobservable, sampled-data, resonance, limits, PES, SRS,
dual-stage and SSA commands: a unit suffix on every dimensional key, the others in the
dimensionless list of docs/CONVENTIONS.md (issue 23, item 4)."""

from __future__ import annotations

import json

import pytest
from test_cli_vocabulary import _keys
from test_cli_vocabulary import (
    test_json_keys_carry_a_unit_or_are_listed_dimensionless as check_keys,
)

import servokit.cli

RUNS = [
    ["identify", "--plant", "vcm-dual-stage", "--controller", "table-5.2", "--fmin", "20000",
     "--fmax", "21000", "--freq-step", "500"],
    ["filter", "peak", "--freq", "4449", "--damping", "0.015", "--gain", "0.1778", "--phi",
     "2.5414", "--dt", "1e-4"],
    ["margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69"],
    ["switching", "ivc"],
    ["switching", "ivc", "--method", "input"],
    ["switching", "admissible-set", "--condition", "-16:3.9e4"],
    ["switching", "cost-map", "--n-points", "5"],
    ["unobservable", "magnitude", "--freq", "4000", "--dt", "25e-6"],
    ["unobservable", "sampling", "--freq", "4000", "--n-samples", "3"],
    ["unobservable", "time", "--freq", "4000", "--dt", "25e-6", "--n-samples-max", "10"],
    ["dual-stage", "--method", "gain"],
    ["srs", "--freq", "3000"],
    ["limits", "variance", "--num", "40000", "--den", "1,300,0", "--dist-num", "1",
     "--dist-den", "0.01,1"],
    ["limits", "bode-integral", "--num", "0.5,0.1", "--den", "1,-0.5,0.1", "--dt", "1e-4"],
    ["pes", "--n-revolutions", "10"],
    ["sensitivity", "--n-freq", "50"],
    ["ssa", "ddssa"],
    ["ssa", "idssa"],
    ["ssa", "amd"],
    ["ssa", "adaptive", "--duration", "1e-3"],
]  # fmt: skip


#: runs of more than ~5 s (the identification simulation, the admissible-set LPs)
SLOW = {"identify", "switching admissible-set"}


def _param(args: list[str]) -> object:
    key = args[0] if args[0] == "identify" else " ".join(args[:2])
    marks = [pytest.mark.slow] if key in SLOW else []
    return pytest.param(args, marks=marks, id=" ".join(args[:2]))


@pytest.mark.parametrize("args", [_param(a) for a in RUNS])
def test_json_keys_carry_a_unit_or_are_listed(args, capsys, monkeypatch) -> None:
    check_keys(args, capsys, monkeypatch)  # the vocabulary test's own check


def test_one_name_per_concept_across_these_commands(capsys, monkeypatch) -> None:
    """The dB magnitude is ``magnitude_db`` (identify), never ``mag_db``; the SRS ratio is
    ``magnitude_ratio``, never a bare ``magnitude``."""
    seen: set[str] = set()
    for args in (RUNS[0], RUNS[11]):  # identify, srs
        monkeypatch.setattr("sys.argv", ["servokit", *args, "--json"])
        with pytest.raises(SystemExit):
            servokit.cli.main()
        seen |= _keys(json.loads(capsys.readouterr().out), set())
    assert {"magnitude_db", "magnitude_ratio"} <= seen
    assert not seen & {"mag_db", "magnitude", "mag"}
