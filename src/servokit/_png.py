"""PNG files of rendered figures: the pixels as they are, no row filtering (issue 24).

Pillow chooses a filter for every row of a PNG by trying all five PNG filters
(libpng's heuristic); on the report's figures (mostly flat colour) that choice is two
thirds of its encoding time and buys 5 % of the bytes: the 78 figures of ``servokit
reproduce`` encode in 0.95 s with Pillow (zlib level 3, 6.5 MB) and in 0.34 s with
filter type 0 ("None") on every row (zlib level 3, 6.8 MB; timed alone, see
``docs/guide/figures_cost_2.md``).
Pillow has no option to fix the filter, hence this small writer of the format
(PNG specification, ISO/IEC 15948, sections 5 and 11): signature, ``IHDR``, ``pHYs``
(the resolution), one text chunk per metadata key, one ``IDAT``, ``IEND``.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping

import numpy as np

__all__ = ["encode_png"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    """One chunk: length, type, data, CRC-32 of type and data (PNG section 5.3)."""
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _text_chunk(key: str, value: str) -> bytes:
    """``tEXt`` if the value is Latin-1 (as Pillow writes it), ``iTXt`` (UTF-8) otherwise."""
    try:
        return _chunk(b"tEXt", key.encode("latin-1") + b"\0" + value.encode("latin-1"))
    except UnicodeEncodeError:
        # keyword, no compression (flag, method), empty language tag and translated key
        head = key.encode("latin-1") + b"\0\0\0\0\0"
        return _chunk(b"iTXt", head + value.encode("utf-8"))


def encode_png(
    rgba: np.ndarray, *, dpi: float, text: Mapping[str, str] | None = None, level: int = 3
) -> bytes:
    """The bytes of a PNG file holding an 8-bit RGBA image, every row unfiltered.

    Parameters
    ----------
    rgba : numpy.ndarray of uint8, shape (height, width, 4)
        The pixels, top row first (a figure canvas's ``buffer_rgba()``).
    dpi : float
        Resolution written in the ``pHYs`` chunk [pixels per inch].
    text : mapping of str to str, optional
        Metadata (e.g. ``{"Title": ...}``), one text chunk per key.
    level : int
        zlib compression level, 0 (none) to 9.

    Returns
    -------
    bytes
        The PNG file.
    """
    image = np.asarray(rgba, dtype=np.uint8)
    if image.ndim != 3 or image.shape[2] != 4:
        raise ValueError(f"rgba must have shape (height, width, 4), got {image.shape}")
    height, width = image.shape[:2]
    rows = np.zeros((height, 4 * width + 1), dtype=np.uint8)  # first byte: filter 0
    rows[:, 1:] = image.reshape(height, 4 * width)
    # 8 bits per sample, colour type 6 (RGBA), deflate, adaptive filtering, no interlace
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    ppm = int(dpi / 0.0254 + 0.5)  # pixels per metre, rounded as Pillow does
    parts = [_SIGNATURE, _chunk(b"IHDR", ihdr), _chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1))]
    parts += [_text_chunk(k, v) for k, v in (text or {}).items()]
    parts += [_chunk(b"IDAT", zlib.compress(rows.tobytes(), level)), _chunk(b"IEND", b"")]
    return b"".join(parts)
