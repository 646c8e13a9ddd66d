"""read_frf: every accepted form returns the same FRF; bad data names file, row, column."""

from __future__ import annotations

import os

import numpy as np
import pytest
import scipy.io
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.models import FrfFileError, read_frf, save_frf

PLANT = sk.models.hdd_benchmark()
F = np.geomspace(50.0, 20e3, 40)
P = PLANT.freqresp(F)


def _csv(path, header, rows):
    path.write_text(
        header + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n"
    )
    return path


@pytest.mark.parametrize(
    "header, cols",
    [
        ("freq_hz,re,im", lambda p: (p.real, p.imag)),
        ("FREQ_HZ,Mag_dB,Phase_Deg", lambda p: (20 * np.log10(abs(p)), np.angle(p, deg=True))),
        ("freq_hz,mag,phase_rad", lambda p: (abs(p), np.angle(p))),
    ],
)
def test_csv_forms_agree_with_the_plant(tmp_path, header, cols):
    a, b = cols(P)
    path = _csv(tmp_path / "p.csv", header, zip(F, a, b, strict=True))
    f, r = read_frf(path)
    np.testing.assert_allclose(f, F, rtol=0)
    np.testing.assert_allclose(r, P, rtol=1e-12)


def test_comments_extra_columns_and_semicolons(tmp_path):
    text = "# measured 2026\nfreq_hz;coherence;re;im\n" + "".join(
        f"{float(f)!r};0.9;{float(p.real)!r};{float(p.imag)!r}\n" for f, p in zip(F, P, strict=True)
    )
    (tmp_path / "p.txt").write_text(text)
    np.testing.assert_allclose(read_frf(tmp_path / "p.txt")[1], P, rtol=1e-12)


def test_npz_mat_frd_and_round_trip(tmp_path):
    frd = PLANT.to_frd(F)
    np.savez(tmp_path / "frd.npz", omega=frd.omega, frdata=frd.frdata)
    np.savez(tmp_path / "c.npz", freq_hz=F, response=P)
    scipy.io.savemat(
        tmp_path / "m.mat",
        {"freq_hz": F, "mag_db": 20 * np.log10(abs(P)), "phase_deg": np.angle(P, deg=True)},
    )
    for src in (frd, tmp_path / "frd.npz", tmp_path / "c.npz", tmp_path / "m.mat"):
        f, r = read_frf(src)
        np.testing.assert_allclose(f, F, rtol=1e-12)
        np.testing.assert_allclose(r, P, rtol=1e-10)
    for name in ("s.csv", "s.npz"):
        save_frf(tmp_path / name, F, P)
        f, r = read_frf(tmp_path / name)
        assert np.array_equal(f, F) and np.array_equal(r, P)  # repr round-trips exactly


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=2, max_size=20), st.integers(0, 10**6))
def test_csv_round_trip_is_exact(tmp_path_factory, values, seed):
    rng = np.random.default_rng(seed)
    f = np.cumsum(rng.uniform(0.1, 100.0, len(values)))
    r = np.asarray(values) + 1j * rng.standard_normal(len(values))
    path = tmp_path_factory.mktemp("rt") / "x.csv"
    save_frf(path, f, r)
    f2, r2 = read_frf(path)
    assert np.array_equal(f2, f) and np.array_equal(r2, r)


@pytest.mark.parametrize(
    "text, needle",
    [
        ("freq_hz,re,im\n1,2,3\n2,abc,4\n", "row 3, column 're'"),
        ("freq_hz,re,im\n1,2,3\n2,nan,4\n", "row 3, column 're'"),
        ("freq_hz,re,im\n1,2,3\n1,2,3\n", "row 3, column 'freq_hz'"),
        ("freq_hz,re,im\n1,2,3\n-2,2,3\n", "row 3, column 'freq_hz'"),
        ("# c\nfreq_hz,re,im\n1,2,3\n2,2\n", "row 4"),
        ("freq_hz,re\n1,2\n2,3\n", "column 'im'"),
        ("freq_hz,re,im,mag_db,phase_deg\n1,2,3,4,5\n2,2,3,4,5\n", "several response"),
        ("f,re,im\n1,2,3\n2,2,3\n", "'freq_hz'"),
        ("freq_hz,mag,phase_rad\n1,2,3\n2,-1,0\n", "row 3, column 'mag'"),
        ("freq_hz,re,im\n1,2,3\n", "at least 2"),
        ("# only a comment\n", "no header"),
    ],
)
def test_bad_csv_one_line_naming_file_row_column(tmp_path, text, needle):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FrfFileError) as err:
        read_frf(path)
    msg = str(err.value)
    assert needle in msg and str(path) in msg and "\n" not in msg


def test_refuses_non_regular_huge_unknown_and_bad_arrays(tmp_path):
    with pytest.raises(FrfFileError, match="regular file"):
        read_frf(tmp_path)
    with pytest.raises(FrfFileError, match="no such file"):
        read_frf(tmp_path / "none.csv")
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    with pytest.raises(FrfFileError, match="regular file"):  # never blocks on open
        read_frf(fifo)
    big = save_frf(tmp_path / "big.csv", F, P)
    with pytest.raises(FrfFileError, match="limit"):
        read_frf(big, max_bytes=100)
    (tmp_path / "x.xlsx").write_text("x")
    with pytest.raises(FrfFileError, match="unknown FRF file type"):
        read_frf(tmp_path / "x.xlsx")
    np.savez(tmp_path / "nan.npz", freq_hz=F, re=np.where(F > 1000, np.nan, 1.0), im=0 * F)
    k = int(np.argmax(F > 1000)) + 1
    with pytest.raises(FrfFileError, match=f"row {k}, column 're'"):
        read_frf(tmp_path / "nan.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(FrfFileError, match="not a readable"):
        read_frf(tmp_path / "junk.npz")
    with pytest.raises(TypeError):
        read_frf(3.0)
