"""Hostile inputs that must be *accepted* correctly or must not reach outside the run
(issue 23, second pass); the refusals are rows of tests/test_cli_bad_input.py."""

from __future__ import annotations

import codecs
import json

import numpy as np
import pytest

from servokit._io import number_array, staged_output
from servokit.errors import ServokitValueError
from servokit.models import read_frf


def _frf_text() -> str:
    f = 10.0 * 1.05 ** np.arange(40)
    return "freq_hz,re,im\n" + "".join(f"{x!r},{-1 / x**2!r},1e-9\n" for x in f.tolist())


@pytest.mark.parametrize(
    ("encoding", "bom"), [("utf-16-le", codecs.BOM_UTF16_LE), ("utf-8", codecs.BOM_UTF8)]
)
def test_frf_with_a_byte_order_mark_reads_as_the_utf8_file(tmp_path, encoding, bom) -> None:
    (tmp_path / "plain.csv").write_text(_frf_text())
    (tmp_path / "marked.csv").write_bytes(bom + _frf_text().encode(encoding))
    f0, h0 = read_frf(tmp_path / "plain.csv")
    f1, h1 = read_frf(tmp_path / "marked.csv")
    np.testing.assert_array_equal(f0, f1)
    np.testing.assert_array_equal(h0, h1)


def test_frf_with_nul_bytes_is_refused_as_binary(tmp_path) -> None:
    (tmp_path / "nul.csv").write_bytes(_frf_text().encode()[:30] + b"\x00" + b"1,2,3\n")
    with pytest.raises(ServokitValueError, match=r"nul\.csv: binary data"):
        read_frf(tmp_path / "nul.csv")


def test_a_planted_manifest_never_deletes_outside_the_output_directory(tmp_path) -> None:
    """The manifest listing a run's files lives in the user's directory: an absolute or
    non-string entry in it must not make the next run delete anything else."""
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    out = tmp_path / "out"
    out.mkdir()
    (out / ".servokit-run.json").write_text(json.dumps([str(victim), 3, "../victim.txt"]))
    with staged_output(out) as stage:
        (stage / "results.json").write_text("{}")
    assert victim.read_text() == "keep me"
    assert (out / "results.json").exists()


@pytest.mark.parametrize(
    ("value", "found"),
    [([1.0, True], "True"), (["1"], "'1'"), ([None], "None"), ([[1.0], 2.0], "equal-length")],
)
def test_number_array_refuses_what_numpy_would_coerce(value, found) -> None:
    with pytest.raises(ServokitValueError, match=found):
        number_array(value, "--input t.json: table 'g'")


def test_number_array_keeps_numbers_exactly() -> None:
    got = number_array([[1, 2.5], [-0.0, 1e-300]], "x")
    np.testing.assert_array_equal(got, [[1.0, 2.5], [-0.0, 1e-300]])


@pytest.mark.parametrize("spelling", ["400", "4e2", "400.0", "+400", "4_00"])
def test_an_integer_flag_takes_any_spelling_of_an_integer(spelling, monkeypatch, capsys) -> None:
    from _cli_run import run_cli

    code, out, err, _ = run_cli(
        ["plant", "bode", "hdd-benchmark", "--n-freq", spelling, "--json"], 60, monkeypatch, capsys
    )
    assert code == 0, err
    assert len(json.loads(out)["freq_hz"]) == 400


def test_seek_n_samples_takes_an_integral_float(monkeypatch, capsys) -> None:
    from _cli_run import run_cli

    code, out, err, _ = run_cli(["seek", "--n-samples", "2e1", "--json"], 60, monkeypatch, capsys)
    assert code == 0, err
    assert json.loads(out)["n_samples"] == 20


def test_an_unsettled_seek_says_so_in_words(monkeypatch, capsys) -> None:
    """N = 3 leaves the benchmark's resonances ringing: never ``inf ms`` (issue 23)."""
    from _cli_run import run_cli

    code, out, err, _ = run_cli(["seek", "--n-samples", "3"], 60, monkeypatch, capsys)
    assert code == 0, err
    assert "does not settle" in out and "inf" not in out


def test_a_format_field_after_a_dot_is_not_rewritten_into_a_flag() -> None:
    """``qM.N`` names a fixed-point format, not the --n-samples parameter ``N``."""
    from servokit.cli._app import internal_names_to_flags

    assert internal_names_to_flags("use qM.N with --format c") == "use qM.N with --format c"
    assert internal_names_to_flags("N = 2 is too few") == "--n-samples = 2 is too few"


def test_an_admissible_set_qhull_cannot_draw_is_one_line(tmp_path, monkeypatch, capsys) -> None:
    """A plant whose states differ by decades: the 2-D slice is a sliver qhull rejects.
    Known only after the LPs (so not a bad-input row: a start line may precede it), it
    ends in one error line naming --u-max, never a QhullError traceback."""
    from _cli_run import run_cli

    monkeypatch.chdir(tmp_path)
    (tmp_path / "P.toml").write_text(
        "gain = 1.0\ndelay = 1e-5\n[[modes]]\nfreq_hz = 0.0\ndamping = 0.0\nresidue = 1.0\n"
        "[[modes]]\nfreq_hz = 4000.0\ndamping = 0.05\nresidue = -0.5\n"
    )
    args = ["switching", "admissible-set", "--plant", "P.toml", "--dt", "1e-4", "--freq", "100"]
    code, out, err, _ = run_cli(args, 60, monkeypatch, capsys)
    lines = [ln for ln in err.splitlines() if ln.startswith("servokit:")]
    assert code == 2 and out == "" and "Traceback" not in err, err
    assert len(lines) == 1 and "--u-max" in lines[0], err
