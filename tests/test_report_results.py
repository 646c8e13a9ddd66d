"""results.json: row records, summary counts, the shipped schema, atomic writes, Comparison.ok."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.report import CaseResult, Comparison
from servokit.report.results import (
    load_schema,
    results_document,
    row_record,
    summarize,
    write_atomic,
    write_results,
)

KINDS = ("reproduced", "fitted", "assumed", "spec", "consistency")


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
    assert record["within_tolerance"] is False and record["servokit"] is None


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
        "reproduced": 1, "fitted": 1, "assumed": 1, "spec": 1, "consistency": 1,
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
