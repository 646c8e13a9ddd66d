"""servokit._png: the unfiltered PNG writer decodes to its pixels and keeps its metadata."""

from __future__ import annotations

import io
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from servokit._png import encode_png


@settings(max_examples=40, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 40), st.integers(1, 40), st.just(4))))
def test_decodes_to_the_same_pixels(rgba: np.ndarray) -> None:
    # Pillow (an independent decoder, CRCs checked) reads back every pixel
    data = encode_png(rgba, dpi=110)
    with Image.open(io.BytesIO(data)) as img:
        img.load()
        assert img.mode == "RGBA"
        np.testing.assert_array_equal(np.asarray(img), rgba)


def test_metadata_and_resolution() -> None:
    rgba = np.full((3, 5, 4), 255, np.uint8)
    title = "Fig. 5.38 | phase lag 2π·f·τ [deg]"  # not Latin-1: an iTXt chunk
    data = encode_png(rgba, dpi=110, text={"Software": "servokit", "Title": title})
    with Image.open(io.BytesIO(data)) as img:
        assert img.info["Title"] == title
        assert img.info["Software"] == "servokit"
        assert img.info["dpi"] == pytest.approx((110, 110), abs=0.01)


def test_rows_unfiltered_and_level_used() -> None:
    # every row starts with filter byte 0; the IDAT holds zlib at the given level
    rgba = np.arange(2 * 3 * 4, dtype=np.uint8).reshape(2, 3, 4)
    data = encode_png(rgba, dpi=72, level=1)
    start = data.index(b"IDAT") + 4
    length = int.from_bytes(data[start - 8 : start - 4], "big")
    raw = zlib.decompress(data[start : start + length])
    rows = np.frombuffer(raw, np.uint8).reshape(2, 13)
    assert (rows[:, 0] == 0).all()
    np.testing.assert_array_equal(rows[:, 1:].reshape(2, 3, 4), rgba)


def test_rejects_other_shapes() -> None:
    with pytest.raises(ValueError, match="height, width, 4"):
        encode_png(np.zeros((4, 4, 3), np.uint8), dpi=72)
