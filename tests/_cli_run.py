"""Run ``servokit`` in-process under an alarm (the bad-input table and the fuzz test)."""

from __future__ import annotations

import signal
import time

import pytest

import servokit.cli


class Hang(BaseException):
    """Raised by the alarm: a case that neither answered nor refused in time (not an error
    the CLI could turn into exit 2)."""


def run_cli(args: list[str], seconds: int, monkeypatch, capsys) -> tuple[int, str, str, float]:
    """``servokit ARGS`` in the current directory: (exit code, stdout, stderr, seconds)."""
    monkeypatch.setattr("sys.argv", ["servokit", *args])

    def hang(*_: object) -> None:
        raise Hang(f"{' '.join(args)}: no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    start = time.perf_counter()
    try:
        with pytest.raises(SystemExit) as exc:
            servokit.cli.main()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    out, err = capsys.readouterr()
    return int(exc.value.code or 0), out, err, time.perf_counter() - start
