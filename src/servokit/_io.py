"""Writing files atomically: a reader never sees a half-written file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["check_regular_file", "write_atomic"]


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


def check_regular_file(path: Path, *, max_bytes: int, what: str, error: type[Exception]) -> int:
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
    import stat

    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: no such file; give the path of {what}") from None
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{path}: not a regular file; give {what}")
    if st.st_size > max_bytes:
        raise error(
            f"{path}: {st.st_size} bytes, above the {max_bytes}-byte limit for {what}; "
            "give a smaller file"
        )
    if st.st_size == 0:
        raise error(f"{path}: the file is empty; give {what}")
    return int(st.st_size)
