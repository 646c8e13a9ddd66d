"""Every command against a table of bad inputs: exit 2, one stderr line naming the flag.

Each row is a regression test for issue 7 ("Hardening as a user meets it"): non-finite,
zero, negative, huge and wrong-type values, missing/unwritable paths and directories.
The checks: exit status 2, exactly one line on stderr that names the flag, no
traceback, nothing on stdout, nothing written, and done within a few seconds.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from _cli_run import run_cli

HANG_S = 30  # a case still running after this long is reported as a hang
HUGE = "1000000000"  # a count that must be refused before anything is allocated

SIM = ["simulate", "--dt", "1e-4", "--duration", "0.01"]
POLY = ["feedforward", "polynomial"]
MJ = ["feedforward", "minimum-jerk"]
MAG = ["unobservable", "magnitude", "--freq", "4000"]
SAMP = ["unobservable", "sampling", "--freq", "4000"]
TIME = ["unobservable", "time", "--freq", "4000", "--dt", "25e-6"]
IVC = ["switching", "ivc"]
ADM = ["switching", "admissible-set"]
COST = ["switching", "cost-map"]
IDENT = ["identify", "--plant", "vcm-dual-stage", "--controller", "table-5.2"]
NOTCH = ["filter", "notch", "--freq", "4449", "--damping", "0.09"]
PEAK = ["filter", "peak", "--freq", "4449", "--damping", "0.015", "--gain", "0.1778"]
LAG = ["filter", "lag", "--freq", "6900", "--damping", "0.1"]
INV = ["filter", "inverse", "--zero-freq", "4449"]
BODE = ["limits", "bode-integral", "--num", "0.5,0.1", "--den", "1,-0.5,0.1"]
VAR = ["limits", "variance", "--num", "40000", "--den", "1,300,0", "--dist-num", "1"]
XFF = ["export", "feedforward"]
XC = ["export", "controller", "--controller", "eq-4.69"]
XQ = [*XC, "--precision", "q15", "--u-max", "2"]
MARG = ["margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69"]

CASES: list[tuple[list[str], str]] = [
    # ---- plant
    (["plant", "list", "--bogus"], "--bogus"),  # no value to get wrong: an unknown flag
    (["plant", "list", "extra"], "extra"),
    (["plant", "show", ""], "PLANT"),
    (["plant", "show", "."], "PLANT"),
    (["plant", "show", "no-such-plant"], "PLANT"),
    (["plant", "show", "missing.toml"], "PLANT"),
    (["plant", "show", "DIR"], "PLANT"),
    (["plant", "show", "GARBAGE.toml"], "PLANT"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "0"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "nan"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--fmax", "inf"], "--fmax"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "100", "--fmax", "10"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "1"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "-5"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "abc"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "1e9"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", HUGE], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--plot", "DIR"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "DIR/"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "noext"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "fig.pdf"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "missing/fig.png"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--max-memory-mb", "0"], "--max-memory-mb"),
    # ---- simulate
    (["simulate", "--dt", "0", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "-1e-4", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "nan", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "inf", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "1e-4", "--duration", "0", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "inf", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "1e-9", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "1e6", "--step", "1"], "--duration"),
    ([*SIM, "--step", "1", "--substeps", "0"], "--substeps"),
    ([*SIM, "--step", "1", "--substeps", "10000000"], "--substeps"),
    ([*SIM, "--step", "nan"], "--step"),
    (SIM, "--step"),
    ([*SIM, "--step", "1", "--input", "u.txt"], "--input"),
    ([*SIM, "--input", "missing.txt"], "--input"),
    ([*SIM, "--input", "DIR"], "--input"),
    ([*SIM, "--input", "GARBAGE.toml"], "--input"),
    ([*SIM, "--input", "EMPTY.txt"], "--input"),
    ([*SIM, "--step", "1", "--controller", "no-such"], "--controller"),
    ([*SIM, "--step", "1", "--controller", "eq-4.69"], "--controller"),
    ([*SIM, "--step", "1", "--plant", "no-such"], "--plant"),
    ([*SIM, "--step", "1", "--plant", "galvano-scanner", "--variants"], "--variants"),
    ([*SIM, "--step", "1", "--settle-band", "0"], "--settle-band"),
    ([*SIM, "--step", "1", "--plot", "DIR"], "--plot"),
    # ---- feedforward polynomial / minimum-jerk
    ([*POLY, "--n-samples", "0", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "-3", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "1e12", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", HUGE, "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "40", "--dt", "0"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "nan"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--order", "9"], "--order"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--order", "2"], "--order"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--target", "nan"], "--target"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--plot", "noext"], "--plot"),
    ([*MJ, "--dt", "0"], "--dt"),
    ([*MJ, "--dt", "2", "--move-time", "1"], "--dt"),
    ([*MJ, "--dt", "1e-9", "--move-time", "1"], "--max-memory-mb"),
    ([*MJ, "--dt", "1e-12", "--move-time", "1"], "--dt"),  # below the 1 ns period floor
    ([*ADM, "--dt", "1e-9"], "--dt"),  # 2e6 samples per crossover cycle: singular
    ([*MJ, "--dt", "0.1", "--move-time", "0"], "--move-time"),
    ([*MJ, "--dt", "0.1", "--move-time", "inf"], "--move-time"),
    ([*MJ, "--dt", "0.1", "--target", "nan"], "--target"),
    # ---- seek
    (["seek", "--n-samples", "0"], "--n-samples"),
    (["seek", "--n-samples", "abc"], "--n-samples"),
    (["seek", "--n-samples", "10000000"], "--n-samples"),
    (["seek", "--n-samples-max", "100000"], "--n-samples-max"),
    (["seek", "--n-samples-max", "2"], "--n-samples-max"),
    (["seek", "--dt", "0"], "--dt"),
    (["seek", "--dt", "nan"], "--dt"),
    (["seek", "--target", "0"], "--target"),
    (["seek", "--target", "nan"], "--target"),
    (["seek", "--method", "lqr"], "--method"),
    (["seek", "--model", "full"], "--model"),
    (["seek", "--method", "ffsc", "--band-weight", "1:2:3"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "a:b:c:d"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "2000:1000:1:5"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "1000:nan:1:5"], "--band-weight"),
    (["seek", "--method", "fsc", "--band-weight", "1000:2000:1:5"], "--band-weight"),
    (["seek", "--settle-band", "0"], "--settle-band"),
    (["seek", "--settle-band", "-1"], "--settle-band"),
    (["seek", "--plant", "no-such"], "--plant"),
    # ---- report
    (["report", "--plant", "hdd-benchmark"], "--frf"),
    (["report", "--plant", "no-such", "--seek", "BAD.json"], "--plant"),
    (["report", "--plant", "hdd-benchmark", "--seek", "BAD.json"], "--seek"),
    (["report", "--plant", "hdd-benchmark", "--seek", "missing.json"], "--seek"),
    (["report", "--plant", "hdd-benchmark", "--seek", "BAD.json", "--out", "u.txt"], "--out"),
    (["report", "--plant", "hdd-benchmark", "--seek", "BAD.json", "--out", "RO/r"], "--out"),
    (["report", "--plant", "hdd-benchmark", "--seek", "BAD.json", "--out", ""], "--out"),
    (["report", "--plant", "hdd-benchmark", "--seek", "BAD.json", "--n-plants", "0"], "--n-plants"),
    (["report", "--plant", "hdd-benchmark", "--frf", "missing.csv"], "missing.csv"),
    (["report", "--plant", "hdd-benchmark", "--controller", "no-such"], "--controller"),
    (["seek", "--method", "robust", "--u-max", "1", "--variations", "missing.toml"], "missing"),
    (["seek", "--method", "robust", "--u-max", "1", "--variations", "GARBAGE.toml"], "GARBAGE"),
    (["seek", "--method", "robust", "--u-max", "1", "--variations", "DIR"], "DIR"),
    (["seek", "--method", "fsc", "--variations", "GARBAGE.toml"], "--variations"),
    (
        ["seek", "--method", "robust", "--variations", "GARBAGE.toml", "--n-validation", "0"],
        "--n-validation",
    ),
    (
        ["seek", "--method", "robust", "--variations", "GARBAGE.toml", "--n-validation", HUGE],
        "--n-validation",
    ),
    (["seek", "--plant", "galvano-scanner"], "--dt"),
    (["seek", "--plot", "noext"], "--plot"),
    # ---- sensitivity
    (["sensitivity", "--fmin", "0"], "--fmin"),
    (["sensitivity", "--fmin", "100", "--fmax", "10"], "--fmin"),
    (["sensitivity", "--fmax", "nan"], "--fmax"),
    (["sensitivity", "--n-freq", "1"], "--n-freq"),
    (["sensitivity", "--n-freq", HUGE], "--n-freq"),
    (["sensitivity", "--tol", "0"], "--tol"),
    (["sensitivity", "--tol", "2"], "--tol"),
    (["sensitivity", "--tol", "nan"], "--tol"),
    (["sensitivity", "--band-limit", "0"], "--band-limit"),
    (["sensitivity", "--band-limit", "-1"], "--band-limit"),
    (["sensitivity", "--m", "0"], "--m"),
    (["sensitivity", "--controller", "no-such"], "--controller"),
    (["sensitivity", "--plant", "no-such"], "--plant"),
    (["sensitivity", "--plot", "DIR"], "--plot"),
    (["sensitivity", "--plant", "BIG.toml"], "--max-memory-mb"),
    (["sensitivity", "--max-memory-mb", "inf"], "--max-memory-mb"),
    # ---- unobservable
    (["unobservable", "magnitude", "--freq", "0", "--dt", "25e-6"], "--freq"),
    (["unobservable", "magnitude", "--freq", "nan", "--dt", "25e-6"], "--freq"),
    ([*MAG, "--dt", "0"], "--dt"),
    ([*MAG, "--dt", "-1"], "--dt"),
    ([*MAG, "--dt", "25e-6", "--damping", "1"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "-0.1"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "nan"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "0.1"], "--n-samples"),
    ([*MAG, "--dt", "25e-6", "--n-samples", "0"], "--n-samples"),
    ([*MAG, "--dt", "25e-6", "--n-samples", HUGE], "--n-samples"),
    ([*SAMP, "--level", "0"], "--level"),
    ([*SAMP, "--level", "nan"], "--level"),
    ([*SAMP, "--n-samples", "0"], "--n-samples"),
    ([*SAMP, "--n-samples", "10000000"], "--n-samples"),
    ([*SAMP, "--fs-min", "10", "--fs-max", "5"], "--fs-min"),
    ([*SAMP, "--fs-min", "nan"], "--fs-min"),
    ([*SAMP, "--dt-min", "1e-3", "--dt-max", "1e-4"], "--dt-min"),
    ([*SAMP, "--dt-min", "nan"], "--dt-min"),
    ([*SAMP, "--dt-max", "-1"], "--dt-max"),
    ([*TIME, "--n-samples-max", "0"], "--n-samples-max"),
    ([*TIME, "--n-samples-max", "10000000"], "--n-samples-max"),
    ([*TIME, "--n-samples-max", "10000"], "--n-samples-max"),
    ([*TIME, "--level", "-1"], "--level"),
    (["unobservable", "time", "--freq", "4000", "--dt", "0"], "--dt"),
    # ---- srs
    (["srs", "--input", "missing.txt", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "DIR", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "GARBAGE.toml", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "polynomial"], "--dt"),
    (["srs", "--dt", "0"], "--dt"),
    (["srs", "--dt", "nan"], "--dt"),
    (["srs", "--duration", "0"], "--duration"),
    (["srs", "--n-freq", "1"], "--n-freq"),
    (["srs", "--n-freq", HUGE], "--n-freq"),
    (["srs", "--fmin", "0"], "--fmin"),
    (["srs", "--fmin", "10", "--fmax", "5"], "--fmin"),
    (["srs", "--input", "polynomial", "--dt", "25e-6", "--n-samples", "0"], "--n-samples"),
    (["srs", "--input", "polynomial", "--dt", "1e-6", "--n-samples", "10000000"], "--n-samples"),
    (["srs", "--freq", "0"], "--freq"),
    (["srs", "--freq", "nan"], "--freq"),
    (["srs", "--kind", "peak"], "--kind"),
    (["srs", "--damping", "1"], "--damping"),
    (["srs", "--plot", "DIR"], "--plot"),
    (["srs", "--freq", "1e300"], "--freq"),
    (["srs", "--freq", "1e9", "--kind", "initial"], "--freq"),  # 3.2e7 integration panels
    (["srs", "--kind", "initial", "--fmax", "1e8"], "--fmax"),
    (["srs", "--max-memory-mb", "inf"], "--max-memory-mb"),
    # ---- reproduce
    (["reproduce", "--out", "u.txt"], "--out"),
    (["reproduce", "--out", "u.txt/sub"], "--out"),
    (["reproduce", "--case", "no-such", "--out", "fresh"], "--case"),
    (["reproduce", "--svg=yes", "--out", "fresh"], "--svg"),
    # ---- feedforward: the flags the first rows leave out
    ([*POLY, "--n-samples", "abc", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "40", "--dt", "-1e-4"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "inf"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--target", "inf"], "--target"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--plot", "DIR"], "--plot"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--plot", "RO/fig.png"], "--plot"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--max-memory-mb", "0"], "--max-memory-mb"),
    ([*MJ, "--dt", "nan"], "--dt"),
    ([*MJ, "--dt", "-0.1"], "--dt"),
    ([*MJ, "--dt", "abc"], "--dt"),
    ([*MJ, "--dt", "0.1", "--move-time", "-1"], "--move-time"),
    ([*MJ, "--dt", "0.1", "--plot", "fig.pdf"], "--plot"),
    ([*MJ, "--dt", "0.1", "--plot", "RO/fig.svg"], "--plot"),
    # ---- sweep
    (["sweep", "--n-variants", "0"], "--n-variants"),
    (["sweep", "--n-variants", "-5"], "--n-variants"),
    (["sweep", "--n-variants", "abc"], "--n-variants"),
    (["sweep", "--n-variants", HUGE], "--n-variants"),
    (["sweep", "--target", "nan"], "--target"),
    (["sweep", "--target", "0"], "--target"),
    (["sweep", "--tracks", "inf"], "--target"),
    (["sweep", "--settle-band", "0"], "--settle-band"),
    (["sweep", "--settle-band", "nan"], "--settle-band"),
    (["sweep", "--n-samples", "0"], "--n-samples"),
    (["sweep", "--n-samples", HUGE], "--n-samples"),
    (["sweep", "--method", "lqr"], "--method"),
    (["sweep", "--method", "robust"], "--u-max"),
    (["sweep", "--method", "robust", "--u-max", "0"], "--u-max"),
    (["sweep", "--method", "robust", "--u-max", "nan"], "--u-max"),
    (["sweep", "--method", "fsc", "--u-max", "0"], "--u-max"),  # clip of any design
    (["sweep", "--method", "fsc", "--u-max", "-1"], "--u-max"),
    (["sweep", "--slew-max", "0"], "--slew-max"),
    (["sweep", "--slew-max", "nan"], "--slew-max"),
    (["sweep", "--slew-max", "abc"], "--slew-max"),
    (["sweep", "--chunk-size", "0"], "--chunk-size"),
    (["sweep", "--chunk-size", HUGE], "--chunk-size"),
    (["sweep", "--workers", "0"], "--workers"),
    (["sweep", "--seed", "-1"], "--seed"),
    (["sweep", "--design", "missing.json"], "--design"),
    (["sweep", "--design", "DIR"], "--design"),
    (["sweep", "--design", "GARBAGE.toml"], "--design"),
    (["sweep", "--design", "EMPTY.txt"], "--design"),
    (["sweep", "--design", "BAD.json"], "--design"),
    (["sweep", "--plot", "DIR"], "--plot"),
    (["sweep", "--plot", "fig.pdf"], "--plot"),
    (["sweep", "--plot", "RO/fig.png"], "--plot"),
    (["sweep", "--max-memory-mb", "0"], "--max-memory-mb"),
    (["sweep", "--n-variants", "100000000", "--max-memory-mb", "1"], "--max-memory-mb"),
    (["sweep", "--max-memory-mb", "inf"], "--max-memory-mb"),
    (["seek", "--max-memory-mb", "inf"], "--max-memory-mb"),
    (["seek", "--max-memory-mb", "1"], "--max-memory-mb"),
    (["seek", "--method", "robust", "--u-max", "1", "--max-memory-mb", "1"], "--max-memory-mb"),
    ([*SIM, "--step", "1", "--max-memory-mb", "inf"], "--max-memory-mb"),
    ([*SIM, "--step", "1", "--duration", "100", "--dt", "1e-6"], "--max-memory-mb"),
    # ---- switching ivc / admissible-set / cost-map
    ([*IVC, "--plant", "no-such"], "--plant"),
    ([*IVC, "--plant", "DIR"], "--plant"),
    ([*IVC, "--plant", "GARBAGE.toml"], "--plant"),
    ([*IVC, "--controller", "no-such"], "--controller"),
    ([*IVC, "--controller", "DIR"], "--controller"),
    ([*IVC, "--controller", "lead-lag", "--freq", "0", "--dt", "3.7879e-5"], "--freq"),
    ([*IVC, "--controller", "lead-lag", "--freq", "nan", "--dt", "3.7879e-5"], "--freq"),
    ([*IVC, "--dt", "0"], "--dt"),
    ([*IVC, "--dt", "nan"], "--dt"),
    ([*IVC, "--dt", "-1"], "--dt"),
    ([*IVC, "--method", "foo"], "--method"),
    ([*IVC, "--weight", "foo"], "--weight"),
    ([*IVC, "--weight", "1,nan"], "--weight"),
    ([*IVC, "--method", "pole-zero", "--poles", "a,b"], "--poles"),
    ([*IVC, "--method", "pole-zero", "--poles", "nan"], "--poles"),
    ([*IVC, "--method", "input", "--pole", "nan"], "--pole"),
    ([*IVC, "--method", "input", "--pole", "2"], "--pole"),
    ([*IVC, "--method", "input", "--order", "-1"], "--order"),
    ([*IVC, "--method", "input", "--order", HUGE], "--order"),
    ([*IVC, "--method", "input", "--input-weight", "-1"], "--input-weight"),
    ([*IVC, "--method", "input", "--jerk-weight", "nan"], "--jerk-weight"),
    ([*IVC, "--n-samples", "1"], "--n-samples"),
    ([*IVC, "--n-samples", HUGE], "--n-samples"),
    ([*IVC, "--plot", "noext"], "--plot"),
    ([*IVC, "--plot", "RO/fig.png"], "--plot"),
    ([*ADM, "--u-max", "0"], "--u-max"),
    ([*ADM, "--u-max", "nan"], "--u-max"),
    ([*ADM, "--u-max", "-1"], "--u-max"),
    ([*ADM, "--condition", "1"], "--condition"),
    ([*ADM, "--condition", "a:b"], "--condition"),
    ([*ADM, "--condition", "nan:0"], "--condition"),
    ([*ADM, "--t-max", "0"], "--t-max"),
    ([*ADM, "--t-max", HUGE], "--t-max"),
    ([*ADM, "--dt", "0"], "--dt"),
    ([*ADM, "--freq", "nan"], "--freq"),
    ([*ADM, "--plant", "missing.toml"], "--plant"),
    ([*ADM, "--max-memory-mb", "0"], "--max-memory-mb"),
    ([*ADM, "--plot", "DIR"], "--plot"),
    ([*ADM, "--plot", "RO/fig.png"], "--plot"),
    ([*COST, "--position", "nan"], "--position"),
    ([*COST, "--vel-range", "1:0"], "--vel-range"),
    ([*COST, "--vel-range", "a:b"], "--vel-range"),
    ([*COST, "--vel-range", "nan:1"], "--vel-range"),
    ([*COST, "--acc-range", "x"], "--acc-range"),
    ([*COST, "--n-points", "1"], "--n-points"),
    ([*COST, "--n-points", HUGE], "--n-points"),
    ([*COST, "--ivc", "foo"], "--ivc"),
    ([*COST, "--dt", "nan"], "--dt"),
    ([*COST, "--freq", "-1"], "--freq"),
    ([*COST, "--controller", "no-such"], "--controller"),
    # ---- sizes estimated before allocating (issue 23): a 20 000-mode plant, a tiny --dt
    ([*IVC, "--plant", "BIG.toml"], "--max-memory-mb"),
    ([*IVC, "--max-memory-mb", "0.5"], "--max-memory-mb"),
    ([*IVC, "--max-memory-mb", "inf"], "--max-memory-mb"),
    ([*ADM, "--plant", "BIG.toml"], "--max-memory-mb"),
    ([*ADM, "--dt", "1e-12"], "--dt"),
    ([*COST, "--plant", "BIG.toml"], "--max-memory-mb"),
    ([*COST, "--position", "1e300"], "--position"),
    ([*NOTCH, "--dt", "1e-300"], "--dt"),
    ([*NOTCH, "--dt", "2e-4"], "--freq"),  # 4449 Hz above the 2500 Hz Nyquist frequency
    ([*NOTCH, "--dt", "nan"], "--dt"),
    # ---- identify
    (["identify", "--plant", "no-such", "--controller", "table-5.2"], "--plant"),
    (["identify", "--plant", "DIR", "--controller", "table-5.2"], "--plant"),
    (["identify", "--plant", "vcm-dual-stage", "--controller", "no-such"], "--controller"),
    (["identify", "--plant", "vcm-dual-stage", "--controller", "missing.toml"], "--controller"),
    ([*IDENT, "--fs", "0"], "--fs"),
    ([*IDENT, "--fs", "nan"], "--fs"),
    ([*IDENT, "--fs", "-3e4"], "--fs"),
    ([*IDENT, "--dt", "0"], "--dt"),
    (["identify", "--plant", "BIG.toml", "--controller", "table-5.2"], "--max-memory-mb"),
    ([*IDENT, "--loop-plant", "BIG.toml"], "--max-memory-mb"),
    ([*MARG, "--plant", "BIG.toml"], "--max-memory-mb"),
    ([*MARG, "--n-freq", "10000000"], "--max-memory-mb"),
    ([*MARG, "--max-memory-mb", "inf"], "--max-memory-mb"),
    ([*IDENT, "--dt", "1e-300"], "--dt"),
    ([*IDENT, "--dt", "nan"], "--dt"),
    ([*IDENT, "--fmin", "0"], "--fmin"),
    ([*IDENT, "--fmin", "100", "--fmax", "10"], "--fmin"),
    ([*IDENT, "--fmax", "inf"], "--fmax"),
    ([*IDENT, "--freq-step", "0"], "--freq-step"),
    ([*IDENT, "--freq-step", "nan"], "--freq-step"),
    ([*IDENT, "--freq-step", "1e-6"], "--freq-step"),
    ([*IDENT, "--substeps", "0"], "--substeps"),
    ([*IDENT, "--substeps", HUGE], "--substeps"),
    ([*IDENT, "--loop-plant", "no-such"], "--loop-plant"),
    ([*IDENT, "--max-memory-mb", "0"], "--max-memory-mb"),
    ([*IDENT, "--plot", "DIR"], "--plot"),
    ([*IDENT, "--plot", "RO/fig.png"], "--plot"),
    # ---- filter notch / peak / lag / inverse
    (["filter", "notch", "--freq", "0", "--damping", "0.09"], "--freq"),
    (["filter", "notch", "--freq", "nan", "--damping", "0.09"], "--freq"),
    (["filter", "notch", "--freq", "-1", "--damping", "0.09"], "--freq"),
    (["filter", "notch", "--freq", "abc", "--damping", "0.09"], "--freq"),
    (["filter", "notch", "--freq", "4449", "--damping", "-0.1"], "--damping"),
    (["filter", "notch", "--freq", "4449", "--damping", "nan"], "--damping"),
    ([*NOTCH, "--filter-freq", "0"], "--filter-freq"),
    ([*NOTCH, "--filter-freq", "inf"], "--filter-freq"),
    ([*NOTCH, "--filter-damping", "nan"], "--filter-damping"),
    ([*NOTCH, "--filter-damping", "-1"], "--filter-damping"),
    ([*NOTCH, "--dt", "0"], "--dt"),
    ([*NOTCH, "--dt", "nan"], "--dt"),
    ([*NOTCH, "--dt", "1e-3"], "--dt"),
    ([*NOTCH, "--plot", "noext"], "--plot"),
    ([*NOTCH, "--plot", "RO/fig.png"], "--plot"),
    ([*PEAK, "--phi", "nan"], "--phi"),
    ([*PEAK, "--phi", "inf"], "--phi"),
    (
        ["filter", "peak", "--freq", "0", "--damping", "0.015", "--gain", "1", "--phi", "1"],
        "--freq",
    ),
    (
        ["filter", "peak", "--freq", "4449", "--damping", "0.015", "--gain", "nan", "--phi", "1"],
        "--gain",
    ),
    ([*PEAK, "--phi", "1", "--dt", "-1"], "--dt"),
    ([*PEAK, "--phi", "1", "--plot", "DIR"], "--plot"),
    ([*LAG, "--phase", "nan"], "--phase"),
    ([*LAG, "--phase", "inf"], "--phase"),
    (["filter", "lag", "--freq", "6900", "--damping", "-1", "--phase", "1"], "--damping"),
    ([*LAG, "--phase", "1", "--dt", "inf"], "--dt"),
    ([*LAG, "--phase", "1", "--plot", "fig.pdf"], "--plot"),
    ([*INV, "--pole-freq", "0"], "--pole-freq"),
    ([*INV, "--pole-freq", "nan"], "--pole-freq"),
    (["filter", "inverse", "--zero-freq", "-1", "--pole-freq", "4775"], "--zero-freq"),
    ([*INV, "--pole-freq", "4775", "--zero-damping", "-1"], "--zero-damping"),
    ([*INV, "--pole-freq", "4775", "--pole-damping", "nan"], "--pole-damping"),
    ([*INV, "--pole-freq", "4775", "--dt", "0"], "--dt"),
    ([*INV, "--pole-freq", "4775", "--plot", "DIR/"], "--plot"),
    # ---- hostile files as inputs (issue 23): refused before they are opened or parsed
    *[
        ([*cmd, flag, f], flag)
        for cmd, flag in (
            (["simulate", "--dt", "1e-4", "--duration", "0.01", "--step", "1"], "--plant"),
            (["margins", "--plant", "hdd-sampled-data"], "--controller"),
            (["margins", "--controller", "eq-4.69"], "--plant"),
        )
        for f in ("FIFO", "FIFO.toml", "ZERO.toml", "DEEP.toml", "LATIN.toml", "UTF16.toml")
    ],
    *[
        (["sweep", "--design", f], "--design")
        for f in ("FIFO", "FIFO.json", "ZERO.json", "DEEP.json", "BINARY.json")
    ],
    (["settle", "judge", "--record", "FIFO.csv"], "--record"),
    (["settle", "evaluate", "--judge", "FIFO"], "--judge"),
    (["settle", "train", "--judge", "FIFO"], "--judge"),
    # the own-actuator inputs: FRF files, variation files, seek designs
    *[
        (args, name)
        for f, name in (("FIFO.csv", "FIFO.csv"), ("ZERO.json", "ZERO.json"))
        for args in (
            ["fit", f, "--out", "o"],
            ["loopshape", f, "--dt", "1e-4", "--out", "o"],
            ["report", "--plant", "hdd-benchmark", "--frf", f],
        )
    ],
    *[
        ([*cmd, "--variations", f], "--variations")
        for cmd in (
            ["seek", "--method", "fsc", "--n-samples", "10"],
            ["simulate", "--plant", "hdd-sampled-data", "--dt", "1.535e-4", "--duration",
             "0.01", "--step", "1", "--controller", "eq-4.69"],
            ["margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69"],
            ["sweep", "--method", "fsc", "--n-samples", "10"],
        )  # fmt: skip
        for f in ("FIFO.toml", "ZERO.toml", "DEEP.toml")
    ],
    *[
        (["export", "feedforward", "--seek", f], "--seek")
        for f in ("FIFO.json", "ZERO.json", "DEEP.json", "BINARY.json")
    ],
    # ---- flags that do not apply to the chosen method are refused, not ignored
    (["seek", "--method", "fsc", "--margin", "0.3"], "--margin"),
    (["seek", "--method", "ffsc", "--n-samples", "10", "--u-max", "1e-6"], "--u-max"),
    (["seek", "--method", "fsc", "--objective", "energy"], "--objective"),
    (["sweep", "--method", "fsc", "--u-max", "3"], "--u-max"),
    (["sweep", "--design", "u.txt", "--method", "ffsc"], "--method"),
    # ---- margins
    # a box beyond the corner limit is refused before any plant is built (3^8 corners)
    ([*MARG, "--variations", "BIGBOX.toml"], "--variations"),
    # a typed --plant and a different plant named in the variation file: not one ignored
    ([*MARG, "--variations", "VAR.toml"], "--plant"),
    (["seek", "--plant", "hdd-benchmark", "--variations", "VAR.toml"], "--plant"),
    (["sweep", "--plant", "hdd-benchmark", "--n-variants", "10"], "--plant"),
    # an input designed for 100 never settles at another distance
    (["sweep", "--design", "TGT.json", "--target", "1"], "--target"),
    # the file's words stay the file's words; the plant it names is named as its field
    (["seek", "--variations", "TYPOVAR.toml"], "'freq_hz'"),
    (["seek", "--variations", "MISSPLANT.toml"], "field 'plant'"),
    # a limit no input of that length meets: the flags to change named once
    (["seek", "--target", "10", "--method", "fsc", "--n-samples", "12", "--u-max", "1e-6"],
     "raise --u-max or --n-samples"),  # fmt: skip
    # |T| is 0 dB wherever |L| is large: no loop meets a bound at or below it
    (["loopshape", "FRF.csv", "--dt", "2.5e-5", "--out", "o", "--t-max-db", "0"], "--t-max-db"),
    # a damping typed in percent is not a wide notch
    (["loopshape", "FRF.csv", "--dt", "2.5e-5", "--out", "o", "--notch", "2130:20"], "20 % is 0.2"),
    # the model's own check of a plant file's value names the file
    (["plant", "show", "SLOWDELAY.toml"], "SLOWDELAY.toml: delay"),
    # a variation file given where a plant file goes is named for what it is
    (["plant", "show", "VAR.toml"], "--variations"),
    # a misspelt input name is said so, before the rules of the flags beside it
    (["srs", "--input", "halfsine", "--duration", "0.5e-3", "--dt", "25e-6"], "'halfsine'"),
    ([*MARG, "--loop-delay", "-1"], "--loop-delay"),
    ([*MARG, "--loop-delay", "1e300"], "--loop-delay"),
    ([*MARG, "--delay", "nan"], "--delay"),
    (["margins", "--plant", "no-such", "--controller", "eq-4.69"], "--plant"),
    (["margins", "--plant", "DIR", "--controller", "eq-4.69"], "--plant"),
    (["margins", "--plant", "hdd-sampled-data", "--controller", "no-such"], "--controller"),
    (["margins", "--plant", "hdd-sampled-data", "--controller", "GARBAGE.toml"], "--controller"),
    ([*MARG, "--filter", "notch:abc:0.1"], "--filter"),
    ([*MARG, "--filter", "foo:1:2"], "--filter"),
    ([*MARG, "--filter", "notch:0:0.1"], "--filter"),
    ([*MARG, "--filter", "notch:nan:0.1"], "--filter"),
    ([*MARG, "--filter", "notch:4000"], "--filter"),
    ([*MARG, "--filter", "peak:4000:0.1:nan:1"], "--filter"),
    ([*MARG, "--delay", "nan"], "--delay"),
    ([*MARG, "--delay", "inf"], "--delay"),
    ([*MARG, "--delay", "-1"], "--delay"),
    ([*MARG, "--n-freq", "abc"], "--n-freq"),
    ([*MARG, "--n-freq", "4"], "--n-freq"),
    ([*MARG, "--n-freq", HUGE], "--n-freq"),
    ([*MARG, "--plot", "DIR"], "--plot"),
    ([*MARG, "--plot", "RO/fig.png"], "--plot"),
    ([*MARG, "--delay", "1e300"], "--delay"),
    ([*MARG, "--delay", "1"], "--delay"),
    ([*MARG, "--variations", "no-such.toml"], "--variations"),
    ([*MARG, "--variations", "GARBAGE.toml"], "--variations"),
    ([*MARG, "--variations", "DIR"], "--variations"),
    # ---- dual-stage
    (["dual-stage", "--method", "foo"], "--method"),
    (["dual-stage", "--structure", "foo"], "--structure"),
    (["dual-stage", "--notch-damping", "nan"], "--notch-damping"),
    (["dual-stage", "--notch-damping", "-1"], "--notch-damping"),
    (["dual-stage", "--notch-depth-damping", "-1"], "--notch-depth-damping"),
    (["dual-stage", "--notch-freq-ratio", "0"], "--notch-freq-ratio"),
    (["dual-stage", "--extra-notch-depth-damping", "inf"], "--extra-notch-depth-damping"),
    (["dual-stage", "--method", "inverse", "--pair-pole-damping", "-1"], "--pair-pole-damping"),
    (["dual-stage", "--method", "phase", "--kcv-phase", "nan"], "--kcv-phase"),
    (["dual-stage", "--method", "phase", "--kcm-phase", "inf"], "--kcm-phase"),
    (["dual-stage", "--delay-vcm", "-1"], "--delay-vcm"),
    (["dual-stage", "--delay-pzt", "nan"], "--delay-pzt"),
    (["dual-stage", "--fit", "--maxiter", "0"], "--maxiter"),
    (["dual-stage", "--fit", "--maxiter", HUGE], "--maxiter"),
    (["dual-stage", "--plot", "noext"], "--plot"),
    (["dual-stage", "--plot", "RO/fig.png"], "--plot"),
    # ---- ssa
    (["ssa", "ddssa", "--c-pzt", "0"], "--c-pzt"),
    (["ssa", "ddssa", "--c-pzt", "nan"], "--c-pzt"),
    (["ssa", "ddssa", "--c1", "-2e-9"], "--c1"),
    (["ssa", "ddssa", "--c3", "inf"], "--c3"),
    (["ssa", "ddssa", "--r1", "0"], "--r1"),
    (["ssa", "ddssa", "--r3", "-1"], "--r3"),
    (["ssa", "ddssa", "--freq", "0"], "--freq"),
    (["ssa", "ddssa", "--freq", "nan"], "--freq"),
    (["ssa", "ddssa", "--freq", "abc"], "--freq"),
    (["ssa", "idssa", "--c", "0"], "--c"),
    (["ssa", "idssa", "--r", "-1"], "--r"),
    (["ssa", "idssa", "--k", "nan"], "--k"),
    (["ssa", "idssa", "--k", "0"], "--k"),
    (["ssa", "amd", "--mode", "abc"], "--mode"),
    (["ssa", "amd", "--mode", "5461:2"], "--mode"),
    (["ssa", "amd", "--mode", "0:2:10"], "--mode"),
    (["ssa", "amd", "--mode", "nan:2:10"], "--mode"),
    (["ssa", "amd", "--mode", "5461:-2:10"], "--mode"),
    (["ssa", "adaptive", "--duration", "0"], "--duration"),
    (["ssa", "adaptive", "--duration", "nan"], "--duration"),
    (["ssa", "adaptive", "--duration", "1e6"], "--duration"),
    (["ssa", "adaptive", "--n-modes", "0"], "--n-modes"),
    (["ssa", "adaptive", "--n-modes", "5"], "--n-modes"),
    # ---- limits
    (["limits", "waterbed", "--alpha-db", "nan"], "--alpha-db"),
    (["limits", "waterbed", "--alpha-db", "10"], "--alpha-db"),
    (["limits", "waterbed", "--freq", "0"], "--freq"),
    (["limits", "waterbed", "--freq", "2e4"], "--freq"),
    (["limits", "waterbed", "--dt", "0"], "--dt"),
    (["limits", "waterbed", "--dt", "inf"], "--dt"),
    (["limits", "waterbed", "--plot", "DIR"], "--plot"),
    (["limits", "waterbed", "--plot", "RO/fig.png"], "--plot"),
    (["limits", "bode-integral", "--num", "a,b", "--den", "1,2"], "--num"),
    (["limits", "bode-integral", "--num", "1", "--den", ""], "--den"),
    (["limits", "bode-integral", "--num", "1", "--den", "0"], "--den"),
    (["limits", "bode-integral", "--num", "nan", "--den", "1,2"], "--num"),
    ([*BODE, "--dt", "0"], "--dt"),
    ([*BODE, "--dt", "nan"], "--dt"),
    ([*BODE, "--dt", "1e-4", "--n-freq", HUGE], "--n-freq"),
    ([*BODE, "--plot", "noext"], "--plot"),
    ([*VAR, "--dist-den", "0"], "--dist-den"),
    ([*VAR, "--dist-den", "x"], "--dist-den"),
    ([*VAR, "--dist-den", "0.01,1", "--delta", "nan"], "--delta"),
    ([*VAR, "--dist-den", "0.01,1", "--dt", "-1"], "--dt"),
    ([*VAR, "--dist-den", "0.01,1", "--rolloff-order", "0"], "--rolloff-order"),
    ([*VAR, "--dist-den", "0.01,1", "--rolloff-order", "51"], "--rolloff-order"),
    # an unstable closed loop: (6.13) stays finite on the boundary but is no variance
    (["limits", "variance", "--num", "1", "--den", "1,-3,1", "--dist-num", "1",
      "--dist-den", "0.01,1"], "--num/--den"),
    (["limits", "variance", "--num", "3", "--den", "1,-0.5", "--dist-num", "1",
      "--dist-den", "1,0.5", "--dt", "1e-4"], "--num/--den"),
    ([*BODE, "--dt", "1e-4", "--n-freq", "16777216", "--max-memory-mb", "100"], "--max-memory-mb"),
    ([*BODE, "--dt", "1e-4", "--max-memory-mb", "inf"], "--max-memory-mb"),
    ([*BODE, "--dt", "1e-4", "--max-memory-mb", "0"], "--max-memory-mb"),
    (["limits", "dynamic-range", "--stroke-m", "0", "--accuracy-m", "3e-9"], "--stroke-m"),
    (["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "nan"], "--accuracy-m"),
    (["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "-1"], "--accuracy-m"),
    # ---- settle
    (["settle", "train", "--out", "DIR"], "--out"),
    (["settle", "train", "--judge", "DIR"], "--judge"),
    (["settle", "train", "--out", "missing/judge.skops"], "--out"),
    (["settle", "train", "--out", "RO/judge.skops"], "--out"),
    (["settle", "train", "--n-distances", "1"], "--n-distances"),
    (["settle", "train", "--n-distances", HUGE], "--n-distances"),
    (["settle", "train", "--n-lengths", HUGE], "--n-lengths"),
    (["settle", "train", "--settle-band", "0"], "--settle-band"),
    (["settle", "train", "--settle-band", "nan"], "--settle-band"),
    (["settle", "train", "--svm-c", "0"], "--svm-c"),
    (["settle", "train", "--svm-c", "nan"], "--svm-c"),
    (["settle", "train", "--c", "nan"], "--c"),  # the deprecated old name still works
    (["settle", "train", "--coef0", "inf"], "--coef0"),
    # every simulated seek is kept: the grid's memory is estimated before simulating
    (["settle", "train", "--n-distances", "1000", "--n-lengths", "107"], "--max-memory-mb"),
    (["settle", "train", "--max-memory-mb", "1"], "--max-memory-mb"),
    (["settle", "train", "--max-memory-mb", "inf"], "--max-memory-mb"),
    (["settle", "evaluate", "--n-seeks", "100000"], "--max-memory-mb"),
    (["settle", "evaluate", "--max-memory-mb", "nan"], "--max-memory-mb"),
    (["settle", "evaluate", "--judge", "missing.skops"], "--judge"),
    (["settle", "evaluate", "--judge", "DIR"], "--judge"),
    (["settle", "evaluate", "--judge", "GARBAGE.toml"], "--judge"),
    (["settle", "evaluate", "--n-seeks", "0"], "--n-seeks"),
    (["settle", "evaluate", "--n-seeks", HUGE], "--n-seeks"),
    (["settle", "evaluate", "--judge", "GARBAGE.toml", "--level", "nan"], "--level"),
    (["settle", "evaluate", "--judge", "GARBAGE.toml", "--plot", "DIR"], "--plot"),
    (["settle", "judge", "--judge", "missing.skops"], "--judge"),
    (["settle", "judge", "--judge", "DIR"], "--judge"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--target", "nan"], "--target"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--target", "0"], "--target"),
    (["settle", "judge", "--n-samples", "3"], "--n-samples"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--n-samples", HUGE], "--n-samples"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--record", "missing.csv"], "--record"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--record", "DIR"], "--record"),
    (["settle", "judge", "--judge", "GARBAGE.toml", "--level", "inf"], "--level"),
    # ---- pes
    (["pes", "--plant", "no-such"], "--plant"),
    (["pes", "--plant", "BIG.toml"], "--max-memory-mb"),
    (["pes", "--max-memory-mb", "inf"], "--max-memory-mb"),
    (["pes", "--plant", "DIR"], "--plant"),
    (["pes", "--controller", "no-such"], "--controller"),
    (["pes", "--controller", "DIR"], "--controller"),
    (["pes", "--controller", "GARBAGE.toml"], "--controller"),
    (["pes", "--peak-filter", "abc"], "--peak-filter"),
    (["pes", "--peak-filter", "960:0.08"], "--peak-filter"),
    (["pes", "--peak-filter", "nan:0.08:12"], "--peak-filter"),
    (["pes", "--peak-filter", "0:0.08:12"], "--peak-filter"),
    (["pes", "--peak-filter", "960:-1:12"], "--peak-filter"),
    (["pes", "--peak-filter", "960:0.08:inf"], "--peak-filter"),
    (["pes", "--n-revolutions", "5"], "--n-revolutions"),
    (["pes", "--n-revolutions", "abc"], "--n-revolutions"),
    (["pes", "--n-revolutions", HUGE], "--n-revolutions"),
    (["pes", "--seed", "-1"], "--seed"),
    (["pes", "--max-memory-mb", "0"], "--max-memory-mb"),
    (["pes", "--plot", "DIR"], "--plot"),
    (["pes", "--plot", "noext"], "--plot"),
    (["pes", "--plot", "RO/fig.png"], "--plot"),
    # ---- export
    ([*XFF, "--design", "3"], "--design"),
    ([*XFF, "--seek", "missing.json"], "--seek"),
    ([*XFF, "--seek", "DIR"], "--seek"),
    ([*XFF, "--seek", "GARBAGE.toml"], "--seek"),
    ([*XFF, "--seek", "EMPTY.txt"], "--seek"),
    ([*XFF, "--seek", "BAD.json"], "--seek"),
    ([*XFF, "--seek", "BAD.json", "--n-samples", "5"], "--n-samples"),
    ([*XFF, "--design", "abc"], "--design"),
    ([*XFF, "--target", "nan"], "--target"),
    ([*XFF, "--target", "0"], "--target"),
    ([*XFF, "--n-samples", "0"], "--n-samples"),
    ([*XFF, "--n-samples", HUGE], "--n-samples"),
    ([*XFF, "--format", "pdf"], "--format"),
    ([*XFF, "--precision", "int8"], "--precision"),
    ([*XFF, "--out", "u.txt"], "--out"),
    ([*XFF, "--out", "u.txt/sub"], "--out"),
    ([*XFF, "--out", "RO"], "--out"),
    ([*XFF, "--out", ""], "--out"),
    ([*XFF, "--name", "1abc"], "--name"),
    ([*XFF, "--name", "a-b"], "--name"),
    ([*XFF, "--name", ""], "--name"),
    (["export", "controller", "--controller", "no-such"], "--controller"),
    (["export", "controller", "--controller", "DIR"], "--controller"),
    (["export", "controller", "--controller", "GARBAGE.toml"], "--controller"),
    (["export", "controller", "--controller", "eq-4.69", "--realization", "foo"], "--realization"),
    (["export", "controller", "--controller", "eq-4.69", "--out", "u.txt"], "--out"),
    (["export", "controller", "--controller", "eq-4.69", "--out", "RO/fw"], "--out"),
    (["export", "controller", "--controller", "eq-4.69", "--name", "x y"], "--name"),
    # ---- export controller, fixed point (issue 26)
    ([*XC, "--precision", "q40.1"], "--precision"),
    ([*XC, "--precision", "q1.x"], "--precision"),
    ([*XC, "--precision", "q0.0"], "--precision"),
    ([*XC, "--precision", "q15"], "--u-max"),  # an integrator needs the output limit
    ([*XC, "--precision", "q15", "--u-max", "nan"], "--u-max"),
    ([*XC, "--precision", "q15", "--u-max", "-1"], "--u-max"),
    ([*XC, "--precision", "q15", "--u-max", "0"], "--u-max"),
    ([*XC, "--precision", "q15", "--u-max", "1e-9"], "--u-max"),  # coefficients overflow
    ([*XQ, "--input-max", "0"], "--input-max"),
    ([*XQ, "--input-max", "inf"], "--input-max"),
    ([*XQ, "--rounding", "up"], "--rounding"),
    ([*XQ, "--overflow", "clip"], "--overflow"),
    ([*XQ, "--n-samples", "0"], "--n-samples"),
    ([*XQ, "--n-samples", "abc"], "--n-samples"),
    ([*XQ, "--realization", "df2"], "--realization"),
    ([*XQ, "--out", "u.txt"], "--out"),
    ([*XQ, "--name", "1x"], "--name"),
    ([*XC, "--precision", "q3.12", "--u-max", "2", "--format", "json"], "--format"),
    ([*XC, "--u-max", "0"], "--u-max"),  # float: clamped ss step
    ([*XC, "--u-max", "nan"], "--u-max"),
    ([*XC, "--u-max", "-1"], "--u-max"),
    ([*XC, "--u-max", "2", "--realization", "sos"], "--u-max"),
    ([*XC, "--u-max", "2", "--format", "csv"], "--u-max"),
    ([*XC, "--rounding", "truncate"], "--rounding"),
    ([*XC, "--precision", "q15", "--format", "csv", "--overflow", "wrap"], "--overflow"),
    (["export", "ivc", "--method", "foo"], "--method"),
    (["export", "ivc", "--method", "jmin", "--velocity-weight", "nan"], "--velocity-weight"),
    (["export", "ivc", "--method", "jmin", "--velocity-weight", "-1"], "--velocity-weight"),
    (["export", "ivc", "--out", "u.txt"], "--out"),
    (["export", "ivc", "--name", ""], "--name"),
    (["export", "table", "--input", "missing.json"], "--input"),
    (["export", "table", "--input", "DIR"], "--input"),
    (["export", "table", "--input", "GARBAGE.toml"], "--input"),
    (["export", "table", "--input", "EMPTY.txt"], "--input"),
    (["export", "table", "--input", "BAD.json"], "--input"),
    (["export", "table", "--input", "NAN.csv"], "--input"),
    # hostile table and seek files: checked for size, encoding and nesting before parsing
    *[
        (args, f)
        for f in ("FIFO.json", "ZERO.json", "DEEP.json", "BINARY.json")
        for args in (
            ["export", "table", "--input", f],
            ["report", "--plant", "hdd-benchmark", "--seek", f],
        )
    ],
    # a flag that shapes another method/structure/input kind is refused, never ignored
    ([*IVC, "--method", "jmin", "--pole", "0.5"], "--pole"),
    ([*IVC, "--method", "input", "--weight", "input"], "--weight"),
    ([*IVC, "--method", "jmin", "--jerk-weight", "1"], "--jerk-weight"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--structure", "pid-notch", "--order",
      "4"],
     "--order"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--order", "4", "--notch", "4000:0.1"],
     "--notch"),
    (["export", "ivc", "--method", "pole-zero", "--velocity-weight", "1"], "--velocity-weight"),
    (["dual-stage", "--method", "inverse", "--kcv-phase", "3"], "--kcv-phase"),
    (["dual-stage", "--method", "gain", "--pair-pole-damping", "0.1"], "--pair-pole-damping"),
    (["srs", "--input", "polynomial", "--dt", "25e-6", "--duration", "1e-3"], "--duration"),
    (["srs", "--input", "half-sine", "--target", "2"], "--target"),
    (["srs", "--input", "u.txt", "--dt", "25e-6", "--n-samples", "30"], "--n-samples"),
    # a quotient that underflows is refused, not printed as 0
    (["limits", "dynamic-range", "--stroke-m", "1e300", "--accuracy-m", "1e-300"],
     "--accuracy-m / --stroke-m"),
    # a file's own column names are quoted as written, never rewritten to a flag
    (["fit", "NOFREQ.csv", "--out", "o"], "'freq_hz'"),
    (["export", "table", "--input", "u.txt", "--out", "u.txt"], "--out"),
    (["export", "table", "--input", "u.txt", "--out", "RO"], "--out"),
    # ---- wrong types and missing plot directories across the newer commands
    (["sweep", "--u-max", "abc", "--method", "robust"], "--u-max"),
    (["sweep", "--plot", "missing/fig.png"], "--plot"),
    ([*ADM, "--t-max", "abc"], "--t-max"),
    ([*COST, "--n-points", "abc"], "--n-points"),
    ([*IVC, "--pole", "abc", "--method", "input"], "--pole"),
    ([*IDENT, "--substeps", "abc"], "--substeps"),
    ([*IDENT, "--plot", "missing/fig.svg"], "--plot"),
    ([*NOTCH, "--dt", "abc"], "--dt"),
    ([*MARG, "--plot", "missing/fig.png"], "--plot"),
    (["dual-stage", "--maxiter", "abc"], "--maxiter"),
    (["ssa", "adaptive", "--n-modes", "abc"], "--n-modes"),
    (["ssa", "idssa", "--r", "abc"], "--r"),
    ([*XFF, "--n-samples", "abc"], "--n-samples"),
    (["export", "table", "--input", "u.txt", "--precision", "q7"], "--precision"),
    (["export", "table", "--input", "u.txt", "--out", "u.txt/sub"], "--out"),
    # ---- fit
    (["fit", "missing.csv", "--out", "o"], "FRF_FILE"),
    (["fit", "DIR", "--out", "o"], "FRF_FILE"),
    (["fit", "EMPTY.txt", "--out", "o"], "FRF_FILE"),
    (["fit", "", "--out", "o"], "FRF_FILE"),
    (["fit", "BADFRF.csv", "--out", "o"], "FRF_FILE"),
    (["fit", "NAN.csv", "--out", "o"], "FRF_FILE"),
    (["fit", "GARBAGE.toml", "--out", "o"], "FRF_FILE"),
    (["fit", "FRF.csv"], "--out"),
    (["fit", "FRF.csv", "--out", "u.txt"], "--out"),
    (["fit", "FRF.csv", "--out", "RO/sub"], "--out"),
    (["fit", "FRF.csv", "--out", "o", "--modes", "-1"], "--modes"),
    (["fit", "FRF.csv", "--out", "o", "--modes", "abc"], "--modes"),
    (["fit", "FRF.csv", "--out", "o", "--modes", "1.5"], "--modes"),
    (["fit", "FRF.csv", "--out", "o", "--modes", "9"], "--modes"),
    (["fit", "FRF.csv", "--out", "o", "--band", "5"], "--band"),
    (["fit", "FRF.csv", "--out", "o", "--band", "100:10"], "--band"),
    (["fit", "FRF.csv", "--out", "o", "--band", "a:b"], "--band"),
    (["fit", "FRF.csv", "--out", "o", "--band", "nan:100"], "--band"),
    (["fit", "FRF.csv", "--out", "o", "--band", "1:11"], "--band"),
    (["fit", "FRF.csv", "--out", "o", "--plot", "noext"], "--plot"),
    (["fit", "FRF.csv", "--out", "o", "--plot", "DIR"], "--plot"),
    # ---- loopshape
    (["loopshape", "missing.csv", "--dt", "1e-4", "--out", "o"], "FRF_FILE"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--plant", "no-such"], "--plant"),
    (["loopshape", "DIR", "--dt", "1e-4", "--out", "o"], "FRF_FILE"),
    (["loopshape", "BADFRF.csv", "--dt", "1e-4", "--out", "o"], "FRF_FILE"),
    (["loopshape", "", "--dt", "1e-4", "--out", "o"], "FRF_FILE"),
    (["loopshape", "FRF.csv", "--out", "o"], "--dt"),
    (["loopshape", "FRF.csv", "--dt", "0", "--out", "o"], "--dt"),
    (["loopshape", "FRF.csv", "--dt", "nan", "--out", "o"], "--dt"),
    (["loopshape", "FRF.csv", "--dt", "1e-4"], "--out"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "u.txt"], "--out"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--s-max-db", "-3"], "--s-max-db"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--s-max-db", "nan"], "--s-max-db"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--order", "0"], "--order"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--order", "abc"], "--order"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--structure", "x"], "--structure"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--structure", "order"], "--order"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--notch", "4100"], "--notch"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--notch", "a:0.2"], "--notch"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--notch", "4100:-1"], "--notch"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--lowpass", "-5"], "--lowpass"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--time-limit", "0"], "--time-limit"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--keep-low-gain", "2"],
     "--keep-low-gain"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--controller", "DIR"],
     "--controller"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--controller", "GARBAGE.toml"],
     "--controller"),
    (["loopshape", "FRF.csv", "--dt", "1e-2", "--out", "o"], "FRF_FILE"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--plot", "DIR"], "--plot"),
    (["loopshape", "FRF.csv", "--dt", "1e-4", "--out", "o", "--plot", "noext"], "--plot"),
    # ---- actuator limits (simulate)
    ([*SIM, "--step", "1", "--u-max", "0"], "--u-max"),
    ([*SIM, "--step", "1", "--u-max", "nan"], "--u-max"),
    ([*SIM, "--step", "1", "--u-max", "-2"], "--u-max"),
    ([*SIM, "--step", "1", "--slew-max", "0"], "--slew-max"),
    ([*SIM, "--step", "1", "--slew-max", "inf"], "--slew-max"),
    # ---- --variations (simulate, sweep)
    ([*SIM, "--step", "1", "--variations", "missing.toml"], "--variations"),
    ([*SIM, "--step", "1", "--variations", "DIR"], "--variations"),
    ([*SIM, "--step", "1", "--variations", "GARBAGE.toml"], "--variations"),
    ([*SIM, "--step", "1", "--variations", "EMPTY.txt"], "--variations"),
    ([*SIM, "--step", "1", "--variations", "BADVAR.toml"], "--variations"),
    ([*SIM, "--step", "1", "--variations", "VAR.toml", "--variants"], "--variations"),
    (["seek", "--variations", "missing.toml"], "--variations"),
    (["seek", "--variations", "BADVAR.toml"], "--variations"),
    (["seek", "--method", "fsc", "--n-samples", "12", "--u-max", "0"], "--u-max"),
    (["seek", "--method", "fsc", "--n-samples", "12", "--u-max", "nan"], "--u-max"),
    (["seek", "--method", "fsc", "--n-samples", "12", "--u-max", "1e-6"], "--u-max"),
    (["sweep", "--variations", "missing.toml"], "--variations"),
    (["sweep", "--variations", "DIR"], "--variations"),
    (["sweep", "--variations", "VAR.toml"], "--variations"),
    (["sweep", "--variations", "BADVAR.toml", "--n-variants", "5"], "--variations"),
    # ---- hostile cases of issue 23 found by a second pass (fixed at the reader)
    (["fit", "HUGEFRF.csv", "--out", "o"], "FRF_FILE"),  # |H| 1e300: the fit overflowed
    (["margins", "--plant", "hdd-sampled-data", "--controller", "IMPROPER.toml"], "--controller"),
    (["export", "controller", "--controller", "IMPROPER.toml"], "--controller"),
    (["plant", "show", "HUGEF.toml"], "HUGEF.toml"),  # a 1e300 Hz mode
    *[
        (args, f)
        for f in ("BOOL.json", "DTSTR.json", "DTBIG.json")
        for args in (["sweep", "--design", f], ["export", "feedforward", "--seek", f])
    ],
    (["export", "table", "--input", "BOOL.json"], "BOOL.json"),
    # 100 001 rows: counted before a cell is parsed (1.5e6 rows ran loopshape for minutes)
    *[
        (args, "TALL.csv")
        for args in (
            ["fit", "TALL.csv", "--out", "o"],
            ["loopshape", "TALL.csv", "--dt", "1e-4", "--out", "o"],
            ["report", "--plant", "hdd-benchmark", "--frf", "TALL.csv"],
        )
    ],
    (["fit", "FLAT.csv", "--out", "o"], "FRF_FILE"),  # no rigid body, no mode: was max() of []
    (["export", "table", "--input", "TSTR.json"], "TSTR.json"),
    # a band limit sums every alias order up to it: estimated before the sum (was a hang)
    (["sensitivity", "--band-limit", "1e9"], "--band-limit"),
    (["sensitivity", "--band-limit", "1e8", "--n-freq", "100000"], "--band-limit"),
    # integers: one spelling rule (40, 40.0, 4e1 accepted; fractions, hex, words refused)
    (["plant", "bode", "hdd-benchmark", "--n-freq", "0x10"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "300.5"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "1e400"], "--n-freq"),
    (["sweep", "--n-variants", "2.55e1"], "--n-variants"),
    (["seek", "--n-samples", "20.5"], "--n-samples"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "0x10"], "--fmin"),
    # the flag the user typed, not the library's parameter: a notch above Nyquist
    ([*MARG, "--filter", "notch:4000:0.1"], "--filter notch:4000:0.1"),
    # a bound beyond any float (near Nyquist) or an underflowing --alpha-db
    (["limits", "waterbed", "--freq", "12499"], "--freq"),
    (["limits", "waterbed", "--alpha-db", "-1e300"], "--alpha-db"),
    # --freq shapes only the lead-lag controller: refused with any other, never ignored
    ([*IVC, "--freq", "1e5"], "--freq"),
    (["switching", "cost-map", "--plant", "hdd-sampled-data", "--controller", "eq-4.69",
      "--freq", "300"], "--freq"),  # fmt: skip
    # an unstable disturbance filter: |H|^2 equals the mirrored one's, the variance does not
    ([*VAR, "--dist-den", "-0.01,1"], "--dist-den"),
    (["limits", "variance", "--num", "3", "--den", "1,-0.5", "--dist-num", "1", "--dist-den",
      "1,-2", "--dt", "1e-4"], "--dist-den"),  # fmt: skip
    # an empty entry in a coefficient list is a typo, not a skipped coefficient
    ([*VAR, "--dist-den", "0.01,,1"], "--dist-den"),
    (["limits", "bode-integral", "--num", "1,,2", "--den", "1,0.5"], "--num"),
    # a name the system cannot look at (over 255 bytes): the flag, not a bare OS error
    *[
        (args, flag)
        for args, flag in (
            (["plant", "bode", "hdd-benchmark", "--plot", "a" * 300 + ".png"], "--plot"),
            (["export", "table", "--input", "u.txt", "--out", "a" * 300], "--out"),
            (["fit", "FRF.csv", "--out", "a" * 300], "--out"),
            (["reproduce", "--case", "hdd-seek", "--out", "a" * 300], "--out"),
            (["settle", "train", "--judge", "a" * 300 + ".skops"], "--judge"),
        )
    ],
]

# Known failures: row id ("settle train --c 0") -> reason; none at present. Strict xfail: a
# row marked here turns into an error as soon as its command is fixed, and is then moved out.
KNOWN_FAILURES: dict[str, str] = {}


def _param(args: list[str], flag: str) -> object:
    key = " ".join(args)
    marks = []
    if key in KNOWN_FAILURES:
        marks.append(pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[key]))
    return pytest.param(args, flag, marks=marks, id=key)


def _materialise(args: list[str], where: Path, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Placeholders: DIR an existing directory, GARBAGE.toml an unreadable plant file, ...

    RO is a read-only directory (mode 0o500). Root ignores modes, so as root ``os.access``
    is made to deny writing under RO, as a user without the right would see it.
    """
    (where / "DIR").mkdir(exist_ok=True)
    (where / "GARBAGE.toml").write_text("this is = = not toml [\n")
    (where / "EMPTY.txt").write_text("")
    (where / "u.txt").write_text("1e-3\n-1e-3\n")
    (where / "BAD.json").write_text('{"input": "not numbers", "dt_s": "x"}\n')
    (where / "NAN.csv").write_text("1,nan\n2,3\n")
    f = [10.0 * 1.05**k for k in range(150)]
    (where / "FRF.csv").write_text(
        "freq_hz,re,im\n" + "".join(f"{x!r},{-1 / (6.2832 * x) ** 2!r},1e-9\n" for x in f)
    )
    (where / "BADFRF.csv").write_text("freq_hz,re,im\n10,1,2\n20,x,3\n")
    (where / "NOFREQ.csv").write_text("f,re,im\n10,1,2\n20,1,3\n")
    (where / "VAR.toml").write_text(
        'kind = "variations"\nplant = "galvano-scanner"\ngain_rel = 0.1\n'
    )
    (where / "BIGBOX.toml").write_text(
        'kind = "variations"\nplant = "hdd-sampled-data"\n'
        + "".join(f"[[modes]]\nfreq_hz = {f}\nfreq_rel = 0.05\ndamping_rel = 0.1\n"
                  for f in (4100, 5700, 6200, 7650))
    )  # fmt: skip
    (where / "TYPOVAR.toml").write_text(
        'kind = "variations"\nplant = "hdd-benchmark"\n[[modes]]\nfreq_hz = 4100\nfrq_rel = 0.1\n'
    )
    (where / "MISSPLANT.toml").write_text('kind = "variations"\nplant = "nope.toml"\n')
    (where / "SLOWDELAY.toml").write_text(
        'gain = 1.0\ndelay = 10\n[[modes]]\nfreq_hz = 0\ndamping = 0\nresidue = 1\n'
    )
    (where / "TGT.json").write_text('{"input": [1.0, -1.0], "dt_s": 1e-4, "target_out": 100}')
    (where / "BADVAR.toml").write_text(
        'kind = "variations"\nplant = "hdd-benchmark"\n[[modes]]\nfreq_hz = 3333\nfreq_rel = 0.1\n'
    )
    # hostile files (issue 23): a FIFO (reading or writing it would block), a symlink to an
    # endless device, nesting 1100 deep, Latin-1, UTF-16 and binary bytes
    for name in ("FIFO", "FIFO.toml", "FIFO.json", "FIFO.csv"):
        if not (where / name).exists():
            os.mkfifo(where / name)
    for name in ("ZERO.toml", "ZERO.json"):
        if not (where / name).is_symlink():
            (where / name).symlink_to("/dev/zero")
    (where / "DEEP.toml").write_text("a = " + "[" * 1100 + "]" * 1100 + "\n")
    (where / "DEEP.json").write_text('{"input": ' + "[" * 1100 + "]" * 1100 + "}")
    (where / "LATIN.toml").write_bytes('name = "caf\u00e9"\n'.encode("latin-1"))
    (where / "UTF16.toml").write_bytes("[plant]\n".encode("utf-16"))
    (where / "BINARY.json").write_bytes(bytes(range(256)))
    f = [10.0 * 1.05**k for k in range(150)]
    (where / "HUGEFRF.csv").write_text(
        "freq_hz,re,im\n" + "".join(f"{x!r},1e300,1e300\n" for x in f)
    )
    (where / "IMPROPER.toml").write_text(
        'kind = "controller"\nnum = [1.0, 2.0, 3.0]\nden = [1.0]\ndt = 1e-4\n'
    )
    (where / "HUGEF.toml").write_text(
        "gain = 1.0\n[[modes]]\nfreq_hz = 1e300\ndamping = 0.1\nresidue = 1.0\n"
    )
    if "TALL.csv" in args:  # 1.3 MB: only for its rows
        (where / "TALL.csv").write_text("freq_hz,re,im\n" + "".join(
            f"{10 + k},-1e-6,1e-9\n" for k in range(100_001)
        ))  # fmt: skip
    (where / "FLAT.csv").write_text("freq_hz,re,im\n" + "".join(f"{x!r},1,0\n" for x in f))
    (where / "BOOL.json").write_text('{"input": [true, false], "dt_s": 1e-4}')
    (where / "DTSTR.json").write_text('{"input": [1.0, -1.0], "dt_s": "1e-4"}')
    (where / "DTBIG.json").write_text('{"input": [1.0, -1.0], "dt_s": 1e300}')
    (where / "TSTR.json").write_text('{"gains": ["1", "2"]}')
    # a 20 000-mode plant: its dense discrete model would take ~12 GiB (issue 23)
    if not (where / "BIG.toml").exists():
        modes = "".join(
            f"[[modes]]\nfreq_hz = {100.0 + k}\ndamping = 0.01\nresidue = 1.0\n"
            for k in range(20_000)
        )
        (where / "BIG.toml").write_text('name = "big"\ngain = 1.0\n' + modes)
    ro = where / "RO"
    ro.mkdir(exist_ok=True)
    ro.chmod(0o500)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        real_access = os.access

        def access(path: object, mode: int, *a: object, **k: object) -> bool:
            inside = Path(os.fspath(path)).resolve().is_relative_to(ro.resolve())  # type: ignore[arg-type]
            if mode & os.W_OK and inside:
                return False
            return real_access(path, mode, *a, **k)  # type: ignore[arg-type]

        monkeypatch.setattr(os, "access", access)
    return args


def _snapshot(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


@pytest.mark.parametrize(("args", "flag"), [_param(a, f) for a, f in CASES])
def test_bad_input_is_one_line_exit_2(args, flag, tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    _materialise(args, tmp_path, monkeypatch)
    before = _snapshot(tmp_path)
    code, out, err, elapsed = run_cli(args, HANG_S, monkeypatch, capsys)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("servokit: error: ") or lines[0].startswith("Error")
    assert flag in lines[0], lines[0]
    assert "Traceback" not in err and out == ""
    assert _snapshot(tmp_path) == before, "a refused request wrote files"
    assert elapsed < 5.0, f"refusal took {elapsed:.1f} s"


GROUPS = (
    "plant", "feedforward", "unobservable", "switching", "filter", "ssa", "limits", "settle",
    "export",
)  # fmt: skip


def test_the_table_covers_every_command() -> None:
    commands = {" ".join(a[:2]) if a[0] in GROUPS else a[0] for a, _ in CASES}
    assert commands >= {
        "plant show",
        "plant bode",
        "simulate",
        "feedforward polynomial",
        "feedforward minimum-jerk",
        "seek",
        "sweep",
        "switching ivc",
        "switching admissible-set",
        "switching cost-map",
        "sensitivity",
        "unobservable magnitude",
        "unobservable sampling",
        "unobservable time",
        "srs",
        "identify",
        "filter notch",
        "filter peak",
        "filter lag",
        "filter inverse",
        "margins",
        "dual-stage",
        "ssa ddssa",
        "ssa idssa",
        "ssa amd",
        "ssa adaptive",
        "limits waterbed",
        "limits bode-integral",
        "limits variance",
        "limits dynamic-range",
        "settle train",
        "settle evaluate",
        "settle judge",
        "export feedforward",
        "export controller",
        "export ivc",
        "export table",
        "pes",
        "reproduce",
    }
    assert len(CASES) >= 400


def test_every_registered_command_is_in_the_table() -> None:
    """A new command (or sub-command) must bring its own bad-input rows."""
    import typer.main

    from servokit.cli import _discover, app

    _discover()
    root = typer.main.get_command(app)
    registered = set()
    for name, cmd in root.commands.items():  # type: ignore[attr-defined]
        subs = getattr(cmd, "commands", None)
        registered |= {f"{name} {s}" for s in subs} if subs else {name}
    covered = {" ".join(a[:2]) if a[0] in GROUPS else a[0] for a, _ in CASES}
    assert registered <= covered, sorted(registered - covered)
