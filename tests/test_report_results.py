"""results.json: row records, summary counts, the shipped schema, atomic writes, Comparison.ok."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.report import KINDS, MISS_CLASSES, CaseResult, Comparison, printed_tolerance
from servokit.report.results import (
    load_schema,
    precision_remark,
    results_document,
    row_record,
    summarize,
    write_atomic,
    write_results,
)


def _case(rows: list[Comparison], chapter: int = 2, name: str = "fake") -> CaseResult:
    return CaseResult(name, f"title of {name}", rows, [], chapter=chapter)


# ---- Comparison.ok: its own tests (issue 14) ----
def test_ok_deliberate_miss_and_hit() -> None:
    assert Comparison("x", 1.0, 1.049, rel_tol=0.05).ok
    assert not Comparison("x", 1.0, 1.051, rel_tol=0.05).ok
    assert not Comparison("x", -2.0, 2.0, rel_tol=0.5).ok  # sign error is a miss


def test_ok_zero_book_value_uses_absolute_tolerance() -> None:
    assert Comparison("x", 0.0, 0.004, rel_tol=0.005).ok
    assert not Comparison("x", 0.0, 0.006, rel_tol=0.005).ok
    assert math.isnan(Comparison("x", 0.0, 0.0).ratio)


def test_ok_nan_is_never_within_tolerance() -> None:
    assert not Comparison("x", 1.0, float("nan")).ok
    record = row_record(_case([]), Comparison("x", 1.0, float("nan")))
    assert record["within_tolerance"] is False and record["servokit"] == "NaN"
    assert record["miss_class"] == "open" and record["miss_note"]


def test_known_miss_design_2_ten_tracks_n() -> None:
    # the N search of Design 2 at 10 tracks gives 15, the book prints 17 (exact integer)
    row = Comparison("Design 2 (FFSC), 10 tracks: N", 17.0, 15.0, rel_tol=0.0)
    assert not row.ok
    assert row_record(_case([row]), row)["within_tolerance"] is False


def test_printed_precision_rows_from_issue() -> None:
    assert not Comparison.printed("t", "0.26", 0.2714).ok
    assert Comparison.printed("t", "3", 3.22).ok  # 3 printed means 2.5 .. 3.5


# ---- records and summary ----
def test_row_record_has_the_issue_keys() -> None:
    row = Comparison.printed("gain margin", "4.5", 4.13, unit="dB", source="§4.5.2", kind="spec")
    rec = row_record(_case([row], chapter=4), row)
    assert set(rec) >= {
        "case", "chapter", "source", "quantity", "unit", "book", "servokit", "ratio",
        "tolerance", "within_tolerance", "note", "bound",
    }  # fmt: skip
    assert rec["chapter"] == 4 and rec["book_text"] == "4.5"
    assert rec["ratio"] == pytest.approx(4.13 / 4.5)
    assert rec["within_tolerance"] is False


def test_row_without_book_number_is_not_judged() -> None:
    row = Comparison("no printed value", float("nan"), 3.0, kind="assumed", note="book omits")
    rec = row_record(_case([row]), row)
    assert rec["within_tolerance"] is None and rec["book"] is None and rec["ratio"] is None


def test_summary_counts_by_hand() -> None:
    rows = [
        Comparison("a", 1.0, 1.0),  # reproduced, within
        Comparison("b", 1.0, 2.0),  # reproduced, missed
        Comparison("c", 1.0, 1.0, kind="fitted"),  # within but fitted: not reproduced
        Comparison("d", 1.0, 1.0, kind="consistency"),
        Comparison("e", float("nan"), 1.0, kind="assumed"),
    ]
    recs = [row_record(_case(rows, chapter=3), r) for r in rows]
    recs.append(row_record(_case([], chapter=5), Comparison("f", 2.0, 2.0, kind="spec")))
    s = summarize(recs)
    assert s["total"] == {
        "rows": 6, "judged": 5, "within_tolerance": 4, "missed": 1, "not_comparable": 1,
        "reproduced": 1, "reproduced_kind": 2, "fitted": 1, "assumed": 1, "spec": 1,
        "consistency": 1, "informational": 0, "miss_open": 1, "miss_book_misprint": 0,
        "miss_book_inconsistent": 0, "miss_under_determined": 0, "miss_figure_read": 0,
    }  # fmt: skip
    assert s["chapters"]["3"]["rows"] == 5 and s["chapters"]["5"]["spec"] == 1


_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64), st.integers(-(10**6), 10**6)
)
_rows = st.builds(
    Comparison,
    quantity=st.text(min_size=1, max_size=20),
    book=_numbers,
    servokit=_numbers,
    unit=st.sampled_from(["", "ms", "dB", "Hz"]),
    rel_tol=st.floats(0, 1),
    source=st.text(max_size=10),
    kind=st.sampled_from(KINDS),
    note=st.text(max_size=30),
    bound=st.sampled_from(["", "min", "max"]),
)


@settings(max_examples=60, deadline=None)
@given(
    cases=st.lists(
        st.tuples(st.lists(_rows, max_size=6), st.integers(0, 6)), min_size=1, max_size=4
    )
)
def test_any_document_validates_and_counts_add_up(
    cases: list[tuple[list[Comparison], int]],
) -> None:
    results = [_case(rows, ch, f"case-{i}") for i, (rows, ch) in enumerate(cases)]
    doc = results_document(results, outdir=Path("."), runtimes_s={"case-0": 1.5})
    text = json.dumps(doc, allow_nan=False)  # no NaN can leak into the file
    jsonschema.validate(json.loads(text), load_schema())
    total = doc["summary"]["total"]
    assert total["rows"] == sum(len(r) for r, _ in cases) == len(doc["rows"])
    assert total["judged"] + total["not_comparable"] == total["rows"]
    assert total["within_tolerance"] + total["missed"] == total["judged"]
    assert total["reproduced"] <= total["within_tolerance"]
    assert sum(c["rows"] for c in doc["summary"]["chapters"].values()) == total["rows"]
    for rec, row in zip(doc["rows"], [r for rs, _ in cases for r in rs], strict=True):
        if rec["within_tolerance"] is not None:
            assert rec["within_tolerance"] == row.ok


def test_schema_rejects_a_broken_document() -> None:
    row = Comparison("a", 1.0, 1.0)
    doc = results_document([_case([row])], outdir=Path("."))
    jsonschema.validate(doc, load_schema())
    broken = json.loads(json.dumps(doc))
    del broken["rows"][0]["within_tolerance"]
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, load_schema())
    broken = json.loads(json.dumps(doc))
    broken["rows"][0]["kind"] = "matched"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, load_schema())


def test_schema_ships_as_package_data() -> None:
    text = Path("pyproject.toml").read_text()
    assert "results.schema.json" in text and "templates/*" in text


# ---- atomic writing ----
def test_write_atomic_replaces_whole_file_and_leaves_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "results.json"
    target.write_text("old")
    write_atomic(target, "new content")
    assert target.read_text() == "new content"
    assert [p.name for p in tmp_path.iterdir()] == ["results.json"]
    assert target.stat().st_mode & 0o044  # readable by others like a plain file


def test_write_atomic_failure_keeps_old_file(tmp_path: Path, monkeypatch) -> None:
    target = tmp_path / "report.html"
    target.write_text("complete old page")

    def boom(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr("os.replace", boom)
    with pytest.raises(OSError):
        write_atomic(target, "half")
    assert target.read_text() == "complete old page"
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]


def test_write_results_refuses_nan(tmp_path: Path) -> None:
    with pytest.raises(ValueError):
        write_results({"x": float("nan")}, tmp_path / "r.json")
    assert not (tmp_path / "r.json").exists()


def test_precision_only_miss_says_so() -> None:
    row = Comparison.printed("tau*Ns", "0.26", 0.2714, unit="ms")
    rec = row_record(_case([row]), row)
    assert rec["within_tolerance"] is False
    assert "outside the printed precision only" in rec["note"] and "0.27" in rec["note"]
    far = Comparison.printed("tau*Ns", "0.26", 0.29)  # two units off: a plain miss
    assert "precision" not in row_record(_case([far]), far)["note"]


def test_spec_bounds() -> None:
    gm = Comparison("gain margin", 4.5, 4.13, "dB", rel_tol=0.0, kind="spec", bound="min")
    assert not gm.ok
    assert Comparison("gain margin", 4.5, 4.6, rel_tol=0.0, bound="min").ok
    assert Comparison("|Sd| below 500 Hz", 1.0, 0.9, rel_tol=0.0, bound="max").ok
    assert not Comparison("x", 1.0, float("nan"), bound="max").ok
    assert row_record(_case([gm]), gm)["bound"] == "min"


# ---- issue 21: row vocabulary, miss classes, infinity encoding ----
def test_informational_rows_are_not_judged_even_when_far_off() -> None:
    row = Comparison("seek with delay", 0.333, 0.341, kind="informational", rel_tol=0.001)
    rec = row_record(_case([row]), row)
    assert rec["within_tolerance"] is None and rec["miss_class"] == ""
    assert rec["book"] == 0.333  # the book value is kept, only not judged
    assert summarize([rec])["total"]["informational"] == 1


def test_miss_class_and_note_are_carried_and_counted() -> None:
    rows = [
        Comparison("gm", 4.5, 4.13, rel_tol=0.0, bound="min", kind="spec",
                   miss_class="book_inconsistent", miss_note="(4.69) gives 4.13 dB"),
        Comparison("n", 17.0, 15.0, rel_tol=0.0),  # no class: open
        Comparison("hit", 1.0, 1.0, miss_class="figure_read", miss_note="x"),  # not a miss
    ]  # fmt: skip
    recs = [row_record(_case(rows), r) for r in rows]
    assert [r["miss_class"] for r in recs] == ["book_inconsistent", "open", ""]
    assert recs[0]["miss_note"] == "(4.69) gives 4.13 dB" and recs[2]["miss_note"] == ""
    total = summarize(recs)["total"]
    assert total["miss_book_inconsistent"] == 1 and total["miss_open"] == 1
    assert sum(total[f"miss_{c}"] for c in MISS_CLASSES) == total["missed"] == 2


def test_unknown_kind_or_class_is_refused() -> None:
    with pytest.raises(ValueError, match="kind"):
        Comparison("x", 1.0, 1.0, kind="matched")
    with pytest.raises(ValueError, match="miss_class"):
        Comparison("x", 1.0, 1.0, miss_class="typo")


def test_infinity_is_spelled_out_and_validates() -> None:
    row = Comparison("filter-pole gain margin", float("inf"), float("inf"), rel_tol=0.0)
    finite = Comparison("gain margin", 108.0, float("inf"), rel_tol=0.005)
    doc = results_document([_case([row, finite])], outdir=Path("."))
    text = json.dumps(doc, allow_nan=False)
    back = json.loads(text)
    jsonschema.validate(back, load_schema())
    assert back["rows"][0]["book"] == back["rows"][0]["servokit"] == "Infinity"
    assert back["rows"][1]["servokit"] == "Infinity" and back["rows"][1]["ratio"] == "Infinity"
    assert back["$schema"] == "results.schema.json"
    for rec in back["rows"]:
        if rec["within_tolerance"] is not None:
            assert None not in rec.values()


def test_schema_rejects_null_in_a_judged_row_and_a_miss_without_class() -> None:
    row = Comparison("a", 1.0, 2.0)
    doc = json.loads(json.dumps(results_document([_case([row])], outdir=Path("."))))
    jsonschema.validate(doc, load_schema())
    broken = json.loads(json.dumps(doc))
    broken["rows"][0]["servokit"] = None
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, load_schema())
    broken = json.loads(json.dumps(doc))
    broken["rows"][0]["miss_class"] = ""
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, load_schema())


def test_bound_slack_loosens_the_limit_in_the_right_direction() -> None:
    # a 10 % slack on "greater than 4.5": 4.05 passes, 4.0 fails; "less than 4.5": 4.95
    assert Comparison("gm", 4.5, 4.06, rel_tol=0.1, bound="min").ok
    assert not Comparison("gm", 4.5, 4.0, rel_tol=0.1, bound="min").ok
    assert Comparison("s", 4.5, 4.94, rel_tol=0.1, bound="max").ok
    assert not Comparison("s", 4.5, 5.0, rel_tol=0.1, bound="max").ok


def test_printed_tolerance_is_half_a_unit_exactly() -> None:
    assert printed_tolerance("0.26") == pytest.approx(0.005 / 0.26, rel=1e-12)
    assert printed_tolerance("12") == pytest.approx(0.5 / 12, rel=1e-12)
    assert printed_tolerance("1.51e3") == pytest.approx(5 / 1510, rel=1e-12)
    # a value 0.51 units off misses, 0.49 units off is within
    assert not Comparison.printed("x", "2.0", 2.051).ok
    assert Comparison.printed("x", "2.0", 2.049).ok


def test_precision_remark_threshold_is_one_and_a_half_units() -> None:
    # 1.4 units off: a precision-only miss; 1.6 and 2 units off: a plain miss
    assert precision_remark(Comparison.printed("x", "0.26", 0.274))
    assert not precision_remark(Comparison.printed("x", "0.26", 0.276))
    assert not precision_remark(Comparison.printed("x", "0.26", 0.28))
