"""Safe file input and output.

Output is written atomically (a reader never sees a half-written file; a run's set of
files is staged and swapped in under a lock); input is read only from regular files,
with a size cap checked before reading, a known encoding and a bounded nesting depth.
"""

from __future__ import annotations

import codecs
import os
import re
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from servokit.errors import MAX_INPUT_BYTES, ServokitValueError, check_regular_file

__all__ = [
    "write_atomic",
    "check_data_file",
    "check_regular_file",
    "decode_text",
    "check_nesting",
    "read_input_text",
    "staged_output",
    "number_array",
]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path: Path, data: str | bytes) -> Path:
    """Write ``data`` to a temporary file beside ``path``, then rename it onto ``path``.

    A reader (or an interrupted run) never sees a half-written file: ``path`` is either
    absent, the previous complete file, or the new complete file.

    Parameters
    ----------
    path : Path
        Destination.
    data : str or bytes
        Content (str is written as UTF-8).

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        # mkstemp creates 0600; give the file the mode a plain open() would
        os.chmod(tmp, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


#: Deepest bracket nesting accepted in a TOML/JSON input (a plant file needs about 3).
MAX_NESTING = 64

_STRINGS = re.compile(r'"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'')


def decode_text(raw: bytes, path: str | Path, flag: str, *, plain_utf8: bool = False) -> str:
    """Decode an input file's bytes: UTF-8 (with or without BOM) or UTF-16/32 with a BOM.

    Parameters
    ----------
    raw : bytes
        The file's content.
    path : str or Path
        The file (named in the error).
    flag : str
        The flag that named it.
    plain_utf8 : bool
        Refuse anything but UTF-8 without a byte-order mark (for files a library reads
        itself as UTF-8), naming the encoding found.

    Returns
    -------
    str
    """
    boms = (
        (codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
        (codecs.BOM_UTF8, "utf-8-sig"),
        (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"),
    )  # fmt: skip; UTF-32 first: its LE mark starts with UTF-16's
    codec = next((c for bom, c in boms if raw.startswith(bom)), "utf-8")
    if plain_utf8 and codec != "utf-8":
        raise ServokitValueError(
            f"{flag} {path}: {codec.upper().replace('-SIG', ' with a byte-order mark')} text; "
            "save it as UTF-8 without a byte-order mark"
        )
    try:
        text = raw.decode(codec)
    except UnicodeDecodeError as exc:
        kind = "binary data" if b"\x00" in raw[:4096] else "not UTF-8 text (Latin-1?)"
        raise ServokitValueError(
            f"{flag} {path}: {kind} at byte {exc.start}; save it as UTF-8 text"
        ) from None
    if "\x00" in text:
        raise ServokitValueError(f"{flag} {path}: binary data (NUL bytes); give a text file")
    return text


def check_nesting(text: str, path: str | Path, flag: str, limit: int = MAX_NESTING) -> None:
    """Refuse TOML/JSON text whose brackets nest deeper than ``limit`` (before parsing).

    Parameters
    ----------
    text : str
        The file's text.
    path : str or Path
        The file (named in the error).
    flag : str
        The flag that named it.
    limit : int
        Deepest nesting accepted.
    """
    import numpy as np

    bare = np.frombuffer(_STRINGS.sub("", text).encode("utf-8", "replace"), dtype=np.uint8)
    step = np.isin(bare, (ord("["), ord("{"))).astype(np.int64)
    step -= np.isin(bare, (ord("]"), ord("}")))
    depth = int(np.cumsum(step).max()) if step.size else 0
    if depth > limit:
        raise ServokitValueError(
            f"{flag} {path}: brackets nested {depth} deep, above the limit of {limit}; "
            "flatten the file"
        )


def read_input_text(
    path: str | Path, flag: str, *, max_bytes: int = MAX_INPUT_BYTES, plain_utf8: bool = False
) -> str:
    """Read a text input safely: regular file, size cap, encoding, nesting depth.

    Parameters
    ----------
    path : str or Path
        The file as typed.
    flag : str
        The flag that named it (every error names it and the file).
    max_bytes : int
        Size cap, checked before reading.
    plain_utf8 : bool
        Accept only UTF-8 without a byte-order mark (see :func:`decode_text`).

    Returns
    -------
    str
        The file's text.
    """
    p = check_regular_file(path, flag, max_bytes)
    with open(p, "rb") as fh:
        raw = fh.read(max_bytes + 1)
    text = decode_text(raw, path, flag, plain_utf8=plain_utf8)
    check_nesting(text, path, flag)
    return text


def number_array(value: object, what: str) -> np.ndarray:
    """A JSON value that must be numbers (a number, a list, a list of equal lists) as floats.

    ``json.loads`` hands over booleans, strings and nulls that ``numpy.asarray(...,
    dtype=float)`` would quietly turn into 1.0, parsed numbers or NaN; they are refused.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    what : str
        The flag, file and key it came from (named in the error).

    Returns
    -------
    numpy.ndarray
        The numbers as a float array (ragged lists refused).
    """
    stack = [] if isinstance(value, np.ndarray) and value.dtype.kind in "iuf" else [value]
    while stack:
        v = stack.pop()
        if isinstance(v, list):
            stack.extend(v)
        elif isinstance(v, bool) or not isinstance(v, int | float):
            raise ServokitValueError(f"{what} must hold numbers only (found {v!r}); fix the file")
    try:
        with np.errstate(over="ignore"):
            arr = np.asarray(value, dtype=float)
    except (ValueError, OverflowError):
        raise ServokitValueError(
            f"{what} must be a list of numbers or of equal-length lists; fix the file"
        ) from None
    if not np.all(np.isfinite(arr)):
        raise ServokitValueError(f"{what} holds NaN, inf or a number beyond 1e308; fix the file")
    return arr


#: Staging directories of runs in progress: removed by the CLI's interrupt watchdog too,
#: when it has to end the process before the unwinding reached :func:`staged_output`.
ACTIVE_STAGES: set[Path] = set()

_MANIFEST = ".servokit-run.json"
_LOCK = ".servokit.lock"


@contextmanager
def _locked(out: Path, flag: str) -> Iterator[None]:
    """Hold an exclusive lock on ``out`` for this run; refuse a second concurrent writer."""
    import fcntl

    fd = os.open(out / _LOCK, os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            raise ServokitValueError(
                f"{flag} {out}: another servokit run (pid {holder}) is writing there; "
                "wait for it to finish or choose another directory"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def _swap_in(stage: Path, out: Path) -> None:
    """Move every staged file into ``out`` (each rename atomic), the page last; then remove
    what the previous run wrote and this one did not. SIGINT is held back meanwhile."""
    import json
    import signal

    files = sorted(
        (p.relative_to(stage) for p in stage.rglob("*") if p.is_file()),
        key=lambda r: (r.suffix == ".html", r.suffix == ".json", str(r)),
    )
    old_manifest = out / _MANIFEST
    try:
        listed = json.loads(old_manifest.read_text(encoding="utf-8"))
        previous = {r for r in listed if isinstance(r, str)} if isinstance(listed, list) else set()
    except (OSError, ValueError, TypeError):
        previous = set()
    mask = getattr(signal, "pthread_sigmask", None)
    blocked = mask(signal.SIG_BLOCK, {signal.SIGINT}) if mask else None
    try:
        for rel in files:
            (out / rel).parent.mkdir(parents=True, exist_ok=True)
            os.replace(stage / rel, out / rel)
        for rel in previous - {str(r) for r in files}:
            # the manifest is a file in the user's directory: never follow it outside
            if ".." not in Path(rel).parts and not Path(rel).is_absolute():
                (out / rel).unlink(missing_ok=True)
        write_atomic(out / _MANIFEST, json.dumps(sorted(str(r) for r in files)))
    finally:
        if mask:
            mask(signal.SIG_SETMASK, blocked)


@contextmanager
def staged_output(out: str | Path, flag: str = "--out") -> Iterator[Path]:
    """Write a run's files into a private staging directory; swap them into ``out`` at the end.

    ``out`` is locked for the run, so a second concurrent writer is refused; an interrupted
    or failed run leaves the previous run's files untouched (the staging directory is
    removed); on success the files of this run replace those of the previous one, so
    every file in ``out`` that servokit wrote comes from one run. Files servokit did not
    write are left alone.

    Parameters
    ----------
    out : str or Path
        The output directory (created with its parents).
    flag : str
        The flag that named it (in the error).

    Yields
    ------
    Path
        The staging directory to write into (inside ``out``, so the renames stay atomic).
    """
    import shutil

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with _locked(out, flag):
        for stale in out.glob(".staging-*"):  # left by a run that was killed
            shutil.rmtree(stale, ignore_errors=True)
        stage = Path(tempfile.mkdtemp(prefix=".staging-", dir=out))
        ACTIVE_STAGES.add(stage)
        try:
            yield stage
            _swap_in(stage, out)
        finally:
            shutil.rmtree(stage, ignore_errors=True)
            ACTIVE_STAGES.discard(stage)


def check_data_file(path: Path, *, max_bytes: int, what: str, error: type[Exception]) -> int:
    """Refuse anything but an existing, non-empty regular file of at most ``max_bytes``.

    Checked from ``os.stat`` before a byte is read, so a device, FIFO or huge file never
    blocks or fills memory.

    Parameters
    ----------
    path : Path
        File to check.
    max_bytes : int
        Largest accepted size [bytes].
    what : str
        What the file should be (``"an FRF file (.csv, .npz, .mat)"``), for the messages.
    error : type of Exception
        Exception raised (a :class:`~servokit.errors.ServokitValueError` subclass).

    Returns
    -------
    int
        The file size [bytes].
    """
    # the one regular-file check (errors.check_regular_file), in the caller's error class
    try:
        p = check_regular_file(path, "", max_bytes)
    except ServokitValueError as exc:
        raise error(f"{str(exc).strip()}; expected {what}") from None
    size = p.stat().st_size
    if size == 0:
        raise error(f"{path}: the file is empty; give {what}")
    return int(size)
