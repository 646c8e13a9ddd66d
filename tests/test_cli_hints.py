"""An error from deep inside a numerical library still names the input to change (issue 23)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from servokit.cli._hints import with_input_hint


def test_a_message_naming_a_flag_is_left_alone() -> None:
    msg = "--dt must be > 0 (got 0)"
    assert with_input_hint(msg, ["simulate", "--dt", "0"]) == msg


def test_the_extreme_number_is_named_inside_a_composite_flag() -> None:
    out = with_input_hint("array must not contain infs or NaNs", ["pes", "--peak-filter",
                                                                   "960:1e300:12", "--seed", "3"])
    assert "--peak-filter 960:1e300:12" in out
    assert "--seed" not in out  # 3 is an ordinary number


def test_tiny_nonfinite_and_equals_forms_are_extreme() -> None:
    argv = ["switching", "admissible-set", "--u-max=1e-300", "--freq", "nan", "--dt", "1e-4"]
    out = with_input_hint("Eigenvalues did not converge", argv)
    assert "--u-max 1e-300" in out and "--freq nan" in out and "--dt" not in out


def test_without_extremes_the_number_flags_are_listed() -> None:
    out = with_input_hint("the closed loop 1/(1+L) is unstable",
                          ["limits", "bode-integral", "--num", "-1,0.1", "--den", "1,-0.5,0.1"])
    assert out.endswith("(from the numbers given to --num, --den)")


def test_defaults_only_says_so_without_inventing_a_flag() -> None:
    out = with_input_hint("singular matrix", ["dual-stage"])
    assert "--" not in out and "default inputs" in out


def test_a_named_file_counts_as_named(tmp_path) -> None:
    f = tmp_path / "plant.toml"
    f.write_text("x")
    msg = f"{f}: field 'gain' must be a number"
    assert with_input_hint(msg, ["margins", "--plant", str(f)]) == msg


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_every_number_is_either_ordinary_or_named(x: float) -> None:
    out = with_input_hint("failed", ["cmd", "--x", repr(x)])
    assert "--x" in out  # named either as extreme or among the number flags given
    ordinary = 1e-12 <= abs(x) <= 1e12 or x == 0.0
    assert ("far outside" in out) == (not ordinary)


def test_a_message_naming_a_typed_argument_gets_no_hint() -> None:
    """A missing file or an unknown name is named as typed: no "default inputs" guess."""
    missing = "FRF_FILE nosuch.csv: no such file"
    assert with_input_hint(missing, ["fit", "nosuch.csv", "--out", "o"]) == missing
    shown = "PLANT nosuch.toml: no such file"  # typed as ./nosuch.toml
    assert with_input_hint(shown, ["plant", "show", "./nosuch.toml"]) == shown
    unknown = "PLANT: unknown plant 'nosuch': choose one of hdd-benchmark"
    assert with_input_hint(unknown, ["plant", "show", "nosuch"]) == unknown
    # a word of the command line merely inside another word is not a mention
    vague = "the plant has no modes"
    assert with_input_hint(vague, ["plant", "show", "x.toml"]).endswith(
        "(with the default inputs of this command)"
    )
