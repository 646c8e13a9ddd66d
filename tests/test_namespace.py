"""`servokit.<name>` resolves for every subpackage and `help(servokit)` lists them all."""

from __future__ import annotations

import pkgutil
import pydoc
import subprocess
import sys
import types

import servokit

SUBPACKAGES = sorted(
    info.name for info in pkgutil.iter_modules(servokit.__path__) if not info.name.startswith("_")
)


def test_every_subpackage_and_public_module_is_in_all() -> None:
    assert set(SUBPACKAGES) <= set(servokit.__all__), set(SUBPACKAGES) - set(servokit.__all__)
    assert {"switching", "robust", "export", "seek"} <= set(servokit.__all__)


def test_every_name_resolves_in_a_fresh_interpreter() -> None:
    # a fresh process: nothing imported beforehand, so the lazy __getattr__ does the work
    code = (
        "import servokit, types\n"
        f"for n in {SUBPACKAGES!r}:\n"
        "    assert isinstance(getattr(servokit, n), types.ModuleType), n\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)


def test_help_lists_every_subpackage() -> None:
    text = pydoc.render_doc(servokit, renderer=pydoc.plaintext)
    for name in SUBPACKAGES:
        assert f"servokit.{name}" in text, name
    assert isinstance(servokit.seek, types.ModuleType)
    assert set(SUBPACKAGES) <= set(dir(servokit))
