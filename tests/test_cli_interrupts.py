"""Ctrl-C, interrupted runs and concurrent writers, against real ``servokit`` processes.

SIGINT goes to the whole process group (as a terminal's Ctrl-C does, Dask workers
included); the run must exit 130 within about a second with one stderr line and no
traceback.  An interrupted ``reproduce`` leaves the previous report intact; a second
writer on the same ``--out`` is refused with one line.
"""

from __future__ import annotations

import fcntl
import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
ENTRY = "import sys; from servokit.cli import main; sys.argv[0] = 'servokit'; main()"
#: the watchdog ends an interrupted run after 0.5 s; the rest is slack for a loaded machine
EXIT_WITHIN_S = 2.0


def _start(args: list[str], cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(SRC), COLUMNS="100")
    return subprocess.Popen(
        [sys.executable, "-c", ENTRY, *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, signalled like a terminal's
    )


def _wait_for_stderr(proc: subprocess.Popen, text: str, timeout: float = 300) -> str:
    """Read stderr until ``text`` appears (the run has reached its computing phase)."""
    seen = b""
    end = time.monotonic() + timeout
    fd = proc.stderr.fileno()
    while text.encode() not in seen:
        assert time.monotonic() < end, f"never printed {text!r}: {seen!r}"
        ready, _, _ = select.select([fd], [], [], 1.0)
        if ready:
            chunk = os.read(fd, 4096)
            assert chunk, f"exited before {text!r}: {seen!r}"
            seen += chunk
    return seen.decode()


def _interrupt(proc: subprocess.Popen, seen: str = "") -> tuple[int, float, str]:
    os.killpg(proc.pid, signal.SIGINT)
    start = time.monotonic()
    _, err = proc.communicate(timeout=60)
    return proc.returncode, time.monotonic() - start, seen + err.decode()


def _assert_interrupted(code: int, seconds: float, err: str, before: str = "") -> None:
    assert code == 130, err
    assert seconds < EXIT_WITHIN_S, f"exit took {seconds:.2f} s"
    assert "Traceback" not in err and "Error" not in err, err
    new = [line for line in err[len(before) :].splitlines() if line.strip()]
    assert new == ["servokit: interrupted"], err


def _wait_for_staging(out: Path, timeout: float = 300) -> None:
    """Wait until the run has started writing (its staging directory exists)."""
    end = time.monotonic() + timeout
    while not list(out.glob(".staging-*")):
        assert time.monotonic() < end, "the run never started writing"
        time.sleep(0.05)
    time.sleep(0.5)  # the cases are running


def test_ctrl_c_while_cases_run_exits_130(tmp_path) -> None:
    proc = _start(["reproduce", "--case", "limits", "--out", "o"], tmp_path)
    _wait_for_staging(tmp_path / "o")
    code, seconds, err = _interrupt(proc)
    _assert_interrupted(code, seconds, err)


def test_interrupt_swallowed_by_a_weakref_callback_still_exits_130(tmp_path) -> None:
    """Python ignores an exception raised in a weakref callback; the run must not go on."""
    script = (
        "import sys, time, weakref\n"
        "from servokit.cli._app import _install_interrupt_handling\n"
        "_install_interrupt_handling()\n"
        "class T: pass\n"
        "def slow(_):\n"
        "    print('in callback', file=sys.stderr, flush=True)\n"
        "    time.sleep(30)\n"
        "t = T(); r = weakref.ref(t, slow); del t\n"
        "time.sleep(30)\n"
    )
    _interrupt_script_at(script, "in callback")


def _interrupt_script_at(script: str, marker: str) -> None:
    """Run ``script`` in its own process group, Ctrl-C it once it printed ``marker`` on
    stderr, and check the interrupted exit (130, in time, one line)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", script], env=dict(os.environ, PYTHONPATH=str(SRC)),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    seen = _wait_for_stderr(proc, marker)
    code, seconds, err = _interrupt(proc, seen)
    _assert_interrupted(code, seconds, err, seen)


def test_interrupt_wrapped_by_python_still_exits_130() -> None:
    """Ctrl-C inside ``__set_name__`` while a class is made (matplotlib's axes at import)
    reaches the command as ``RuntimeError`` from ``KeyboardInterrupt`` (Python 3.11): still
    the one line and 130, not a traceback (a make-test run hit it at random)."""
    script = (
        "import sys, time\n"
        "from servokit.cli import _app\n"
        "_app._install_interrupt_handling()\n"
        "class Slow:\n"
        "    def __set_name__(self, owner, name):\n"
        "        print('in set_name', file=sys.stderr, flush=True)\n"
        "        time.sleep(30)\n"
        "class App:\n"
        "    def main(self, **kw):\n"
        "        class Made:\n"
        "            x = Slow()\n"
        "_app.build_command = App\n"
        "sys.exit(_app._run(()))\n"
    )
    _interrupt_script_at(script, "in set_name")


def test_ctrl_c_between_the_steps_of_main_exits_130() -> None:
    """Ctrl-C after the command's module is imported and before it runs (a fresh-clone CI
    run hit ``import click`` in ``_usage_errors``: a traceback and exit -2)."""
    script = (
        "import sys, time\n"
        "from servokit.cli import _app\n"
        "def slow():\n"
        "    print('in usage', file=sys.stderr, flush=True)\n"
        "    time.sleep(30)\n"
        "_app._usage_errors = slow\n"
        "sys.argv = ['servokit', '--version']\n"
        "_app.main()\n"
    )
    _interrupt_script_at(script, "in usage")


def test_from_interrupt_follows_causes_and_contexts() -> None:
    from servokit.cli._app import from_interrupt

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise ValueError("while interrupted") from None  # no cause, a context
    except ValueError as exc:
        assert not from_interrupt(exc)  # `from None` hides the context: not ours
    wrapped = RuntimeError("Error calling __set_name__")
    wrapped.__cause__ = KeyboardInterrupt()
    assert from_interrupt(wrapped)
    loop = ValueError("a")
    loop.__context__ = TypeError("b")
    loop.__context__.__context__ = loop  # a cycle ends the walk
    assert not from_interrupt(loop)


@pytest.mark.slow
def test_ctrl_c_with_dask_workers_exits_130_quietly(tmp_path) -> None:
    pytest.importorskip("distributed")
    proc = _start(
        ["sweep", "--method", "ffsc", "--n-variants", "4000000", "--workers", "2", "--json"],
        tmp_path,
    )
    # the cluster is up and the chunks are running (4e6 variants take minutes: the array
    # path sweeps 4e5 in ~16 s, so a smaller sweep could end before the interrupt)
    time.sleep(20)
    assert proc.poll() is None, proc.communicate()
    code, seconds, err = _interrupt(proc)
    _assert_interrupted(code, seconds, err)


def _previous_report(out: Path) -> dict[str, bytes]:
    out.mkdir()
    files = {"results.json": b'{"old": true}', "report.html": b"<p>old</p>", "fig.png": b"old"}
    for name, data in files.items():
        (out / name).write_bytes(data)
    (out / ".servokit-run.json").write_text(json.dumps(sorted(files)))
    return files


def _contents(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in out.iterdir() if not p.name.startswith(".")}


def test_interrupted_reproduce_keeps_the_previous_report(tmp_path) -> None:
    out = tmp_path / "o"
    files = _previous_report(out)
    proc = _start(["reproduce", "--case", "limits", "--out", "o"], tmp_path)
    _wait_for_staging(out)
    code, seconds, err = _interrupt(proc)
    _assert_interrupted(code, seconds, err)
    assert _contents(out) == files
    assert not list(out.glob(".staging-*")), "the staging directory was left behind"


def test_a_second_writer_on_the_same_out_is_refused(tmp_path) -> None:
    out = tmp_path / "o"
    files = _previous_report(out)
    fd = os.open(out / ".servokit.lock", os.O_RDWR | os.O_CREAT)
    os.write(fd, b"4242")
    fcntl.flock(fd, fcntl.LOCK_EX)  # a run in progress
    try:
        proc = _start(["reproduce", "--case", "limits", "--out", "o"], tmp_path)
        _, err = proc.communicate(timeout=300)
    finally:
        os.close(fd)
    assert proc.returncode == 2, err
    lines = err.decode().strip().splitlines()
    assert lines == [lines[-1]] and "another servokit run (pid 4242)" in lines[0], lines
    assert "--out" in lines[0]
    assert _contents(out) == files


def test_staged_output_swaps_one_runs_files_and_keeps_foreign_ones(tmp_path) -> None:
    from servokit._io import staged_output

    out = tmp_path / "o"
    _previous_report(out)
    (out / "notes.txt").write_text("mine")  # not written by servokit: never touched
    with staged_output(out) as stage:
        (stage / "results.json").write_text("new")
        (stage / "report.html").write_text("new")
        assert _contents(out)["results.json"] == b'{"old": true}'  # nothing swapped yet
    assert _contents(out) == {"results.json": b"new", "report.html": b"new", "notes.txt": b"mine"}
    with pytest.raises(RuntimeError), staged_output(out) as stage:
        (stage / "results.json").write_text("failed run")
        raise RuntimeError("the run failed")
    assert _contents(out)["results.json"] == b"new"
    assert not list(out.glob(".staging-*"))


@pytest.mark.parametrize("after_s", [0.12, 0.3, 0.5, 0.8])
def test_ctrl_c_while_the_command_is_still_importing_exits_130(tmp_path, after_s) -> None:
    """Ctrl-C in the first second (typer, numpy, the command modules importing) is the one
    line and 130 too, not a ``KeyboardInterrupt`` traceback.  Run as the real console
    script: the start-up handler is the ``servokit`` command's only (a library user's
    Ctrl-C stays theirs).  The interpreter's own first ~40 ms (site) are beyond reach."""
    script = Path(sys.executable).parent / "servokit"
    if not script.exists():
        pytest.skip("no servokit console script beside the interpreter")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(SRC))
    proc = subprocess.Popen(
        [str(script), "sweep", "--n-variants", "1e5"], cwd=tmp_path, env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    time.sleep(after_s)
    code, seconds, err = _interrupt(proc)
    if code == 0:  # finished first on a fast machine: nothing to interrupt
        return
    _assert_interrupted(code, seconds, err)
