"""Every code example of README.md and of the Markdown docs pages runs as written.

The fast test checks that every `servokit` subcommand the README names exists and that
every option flag its command lines use appears in that subcommand's ``--help``.  The
slow tests (``make test-all``) execute every ```python block in a fresh namespace and every
`servokit` command line in a temporary directory; the commands the README says take
minutes run with a smaller size (or as ``--help``), see ``_smaller``.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# the README and every Markdown page of the docs (guide, book, performance)
DOC_FILES = [README, *sorted((ROOT / "docs").rglob("*.md"))]
DOC_FILES = [p for p in DOC_FILES if "_build" not in p.parts and p.name != "cli.md"]
# pages whose commands form one session with its own test (run in order, numbers checked):
# their flags are checked here, their commands run there
OWN_TEST = {"docs/guide/own_actuator.md": "tests/test_guide_own_actuator.py"}
EXE = [sys.executable, "-c", "from servokit.cli import main; main()"]

_discover()
runner = CliRunner()


class Where(tuple):
    """(file, line) of a documented example; prints as FILE:LINE."""

    def __new__(cls, name: str, line: int) -> Where:
        return super().__new__(cls, (name, line))

    def __add__(self, k: int) -> Where:  # the line k lines further down the same file
        return Where(self[0], self[1] + k)

    def __str__(self) -> str:
        return f"{self[0]}:{self[1]}"


def _blocks() -> list[tuple[str, Where, str]]:
    """(language, where the opening fence is, body) of every fenced block."""
    out = []
    for path in DOC_FILES:
        text = path.read_text(encoding="utf-8")
        name = path.relative_to(ROOT).as_posix()
        for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M):
            line = text[: m.start()].count("\n") + 1
            out.append((m.group(1), Where(name, line), m.group(2)))
    return out


def _python_blocks() -> list[tuple[int, str]]:
    return [(line, body) for lang, line, body in _blocks() if lang == "python"]


def _shell_lines() -> list[tuple[int, int, list[str]]]:
    """(line of the block, line, words) of every line of the sh/bash/console blocks, with
    continuations joined and ``$`` prompts and trailing comments removed."""
    out = []
    for lang, line, body in _blocks():
        if lang not in ("sh", "bash", "console"):
            continue
        for offset, cmd in _logical_lines(body):
            words = shlex.split(re.sub(r"^\$ ", "", cmd.strip()), comments=True)
            if words:
                out.append((line, line + (1 + offset), words))
    return out


def _chain(words: list[str]) -> list[list[str]]:
    """A ``&&`` chain of `servokit` commands as argv lists without the program name; a
    ``> FILE`` redirection stays in the argv as ``>``, ``FILE``."""
    chain, cur = [], []
    for w in words:
        if w == "&&":
            chain.append(cur)
            cur = []
        else:
            cur.append(w)
    chain.append(cur)
    assert all(c and c[0] == "servokit" for c in chain), " ".join(words)
    return [c[1:] for c in chain]


def _command_lines() -> list[tuple[int, list[list[str]]]]:
    """Every `servokit ...` line of the README's shell blocks as (line, chain)."""
    return [(n, _chain(w)) for _, n, w in _shell_lines() if w[0] == "servokit"]


def _block_scripts() -> list[tuple[int, list[tuple[int, list[str]]]]]:
    """Per shell block with a `servokit` line: its `servokit` and ``echo ... > FILE``
    lines in order (``make``, ``cd bench`` and the example scripts are left out: the
    examples run in test_examples.py)."""
    blocks: dict[int, list[tuple[int, list[str]]]] = {}
    for block, n, words in _shell_lines():
        if block[0] in OWN_TEST:
            continue
        if words[0] == "servokit" or (words[0] == "echo" and ">" in words):
            blocks.setdefault(block, []).append((n, words))
    return [(b, lines) for b, lines in blocks.items() if any(w[0] == "servokit" for _, w in lines)]


def _logical_lines(body: str) -> list[tuple[int, str]]:
    """Lines of a shell block with backslash continuations joined, with their offsets."""
    out, cur, start = [], "", None
    for k, raw in enumerate(body.splitlines()):
        start = k if start is None else start
        if raw.endswith("\\"):
            cur += raw[:-1] + " "
            continue
        out.append((start, cur + raw))
        cur, start = "", None
    return out


PYTHON_BLOCKS = _python_blocks()
COMMANDS = _command_lines()
SCRIPTS = _block_scripts()


def _split_redirect(argv: list[str]) -> tuple[list[str], str | None]:
    if ">" in argv:
        i = argv.index(">")
        return argv[:i], argv[i + 1]
    return argv, None


def _subcommand(argv: list[str]) -> tuple[list[str], list[str], bool]:
    """Split argv into the subcommand path (walking the click tree) and its arguments;
    the flag is False when a group is followed by a word that names none of its
    subcommands."""
    cmd = typer.main.get_command(app)
    path = []
    for word in argv:
        subs = getattr(cmd, "commands", None)
        if not subs or word not in subs:
            break
        cmd = subs[word]
        path.append(word)
    args = argv[len(path) :]
    known = not (hasattr(cmd, "commands") and args and not args[0].startswith("-"))
    return path, args, known


def test_readme_has_examples() -> None:
    assert len(PYTHON_BLOCKS) >= 10 and len(COMMANDS) >= 30


def test_readme_subcommands_and_flags_exist() -> None:
    """Every subcommand named in a README command line has a --help, and every flag the
    line uses is listed there."""
    helps: dict[tuple[str, ...], str] = {}
    problems = []
    for line, chain in COMMANDS:
        for argv in chain:
            argv, _ = _split_redirect(argv)
            path, args, known = _subcommand(argv)
            if not known:
                problems.append(f"{line}: no subcommand `servokit {' '.join(argv)}`")
                continue
            if tuple(path) not in helps:
                res = runner.invoke(app, [*path, "--help"], terminal_width=200)
                if res.exit_code != 0:
                    problems.append(f"{line}: `servokit {' '.join(path)} --help` failed")
                    continue
                helps[tuple(path)] = res.stdout
            flags = set(re.findall(r"(?<![\w-])--?[A-Za-z][\w-]*", helps[tuple(path)]))
            for arg in args:
                flag = arg.split("=", 1)[0]
                if re.match(r"--?[A-Za-z]", flag):  # not a value such as -60 or -16:39370
                    if flag not in flags:
                        problems.append(f"{line}: {flag} not in `servokit {' '.join(path)} --help`")
    assert not problems, "\n".join(problems)


def test_readme_version() -> None:
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.stdout.strip()


# Commands the README says take minutes, or that run long, get a smaller run in the test:
# the whole `reproduce` and the unknowns search as --help, fewer variants and a coarser
# identification grid (~45 s each on the default 50 Hz grid).
def _smaller(argv: list[str]) -> list[str]:
    joined = " ".join(argv)
    if joined == "reproduce" or "--fit" in argv or joined == "reproduce --out out":
        return [*argv, "--help"]
    if "--n-variants" in argv:
        i = argv.index("--n-variants")
        return [*argv[: i + 1], "1000", *argv[i + 2 :]]
    if argv and argv[0] == "identify":
        return [*argv, "--freq-step", "2000"]
    return argv


@pytest.mark.slow
@pytest.mark.parametrize("script", [s for _, s in SCRIPTS], ids=[str(b) for b, _ in SCRIPTS])
def test_readme_commands_run(script: list[tuple[int, list[str]]], tmp_path: Path) -> None:
    """The lines of one shell block, in order, in one directory (the repository's
    examples/ linked into it, so that the pages' paths read as from the repository root)."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    for n, words in script:
        if words[0] == "echo":
            argv, target = _split_redirect(words)
            (tmp_path / target).write_text(" ".join(argv[1:]) + "\n", encoding="utf-8")
            continue
        for argv in _chain(words):
            argv, target = _split_redirect(argv)
            r = subprocess.run(
                [*EXE, *_smaller(argv)], capture_output=True, text=True, timeout=600, cwd=tmp_path
            )
            assert r.returncode == 0, f"{n}: servokit {' '.join(argv)}\n{r.stderr}"
            if target:
                (tmp_path / target).write_text(r.stdout, encoding="utf-8")


@pytest.mark.slow
@pytest.mark.parametrize("line_source", PYTHON_BLOCKS, ids=[str(n) for n, _ in PYTHON_BLOCKS])
def test_readme_python_block_runs(
    line_source: tuple[int, str], tmp_path: Path, monkeypatch
) -> None:
    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    # the performance page's measuring scripts run with bench/ on the path, as they say
    monkeypatch.syspath_prepend(str(ROOT / "bench"))
    try:
        line, source = line_source
        # padded so that a traceback names the README's own line numbers
        namespace: dict[str, object] = {"__name__": "__doc__"}
        exec(compile("\n" * line[1] + source, str(ROOT / line[0]), "exec"), namespace)
        # the block ran to its end: every name it assigns is bound, none to NaN
        import ast

        assigned = {
            t.id
            for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Assign)
            for t in node.targets
            if isinstance(t, ast.Name)
        }
        assert assigned <= set(namespace), sorted(assigned - set(namespace))
        for name in assigned:
            value = namespace[name]
            if isinstance(value, float):
                assert value == value, f"{line[0]}:{line[1]}: {name} is NaN"
    finally:
        plt.close("all")
