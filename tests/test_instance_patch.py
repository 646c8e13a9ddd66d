"""on_instances: an attribute on some objects for a block, removed afterwards."""

from __future__ import annotations

import pytest

from servokit._instance_patch import on_instances


class _Thing:
    def name(self) -> str:
        return "class"


def test_set_for_the_block_and_removed_even_on_error():
    a, b, own = _Thing(), _Thing(), _Thing()
    own.name = lambda: "owner"  # patched by its owner: left alone
    with pytest.raises(RuntimeError):
        with on_instances([a, b, own], "name", lambda obj: lambda: "block") as done:
            assert done == [a, b]
            assert (a.name(), b.name(), own.name()) == ("block", "block", "owner")
            raise RuntimeError
    assert (a.name(), b.name(), own.name()) == ("class", "class", "owner")
    assert "name" not in vars(a) and "name" not in vars(b)
