"""Every fenced code block of README.md and docs/**/*.md runs as a reader would run it, and
prints what the page says it prints (issue 18, item 6: docs that cannot drift).

Conventions (for page writers):

* A page's blocks run in order, in one fresh temporary folder per page that holds a copy of
  the repository's ``examples/``: pages name files relative to the repository's root
  (``examples/models/sdof_paper_ln.toml``), and what the blocks write (``run.nc``) stays in
  the folder, where the page's later blocks find it.
* ```` ```python ````: run in one namespace per page, top to bottom. A statement whose last
  line ends in ``# -> TEXT`` must print ``TEXT`` (``print(r.stats.steps)  # -> 118``).
* ```` ```bash ```` / ```` ```sh ````: every line (``\\`` continues it, ``#`` starts a
  comment) is a ``vibroimpact ...`` command, run as ``python -m vibroimpact ...``; each must
  exit with 0.
* ```` ```console ````: lines starting ``$ vibroimpact`` are commands as above, the lines
  after one are what it prints.
* ```` ```output ````: what the block just before it prints (all of it).
* ```` ```toml ```` with a ``[structure]`` and a ``[solver]`` table: a model file, loaded with
  ``vibroimpact.load_model`` in the page's folder.
* Anything else — an install command, a TOML snippet, a layout, an error message — is marked
  ``<!-- fragment -->`` or ``<!-- fragment: why -->`` on the line before it (blank lines
  between allowed). A fragment is not run (a ``toml`` or ``python`` one must still parse). An
  unmarked block that is none of the above fails the test, so no page adds an unchecked
  block silently. Indented (unfenced) blocks are for formulas and messages: one that holds a
  command or Python code fails too.

Comparing printed text: whitespace is ignored; ``...`` stands for any text (wall times, the
rest of a long table); words and punctuation must be equal; a quoted number matches a
printed one within one unit of its own last digit (``0.00618624`` matches ``0.006186245``;
``477.7`` matches ``477.71179``; ``1.4e-4`` matches 1.3e-4 to 1.5e-4), so a page quotes as
many digits as it vouches for; a quoted integer (``118``) must be printed exactly. A number
may end in ``...`` (``0.00618...``) with the same meaning.
"""

from __future__ import annotations

import ast
import contextlib
import io
import itertools
import operator
import os
import re
import shlex
import shutil
import subprocess
import sys
import tokenize
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import vibroimpact

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]

COMMAND_LANGS = {"bash", "sh", "shell"}
FENCE = re.compile(r"^(?P<fence>```+|~~~+)\s*(?P<lang>[\w+-]*)\s*$")
FRAGMENT = re.compile(r"^<!--\s*fragment(?::\s*(?P<why>.*?))?\s*-->$")
CODE_START = re.compile(r"^(\$ |vibroimpact |python |import |from \S+ import )")
EXPECTED = re.compile(r"#\s*->\s?(?P<text>.*)$")
TOKEN = re.compile(
    r"(?P<ellipsis>\.\.\.)"
    r"|(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(?P<cut>\.\.\.)?(?![\w.])"
    r"|(?P<word>\w+)|(?P<char>\S)")

@dataclass
class Block:
    """One fenced block of a page: where it starts (1-based line of its opening fence), its
    language, its text and, for a fragment, why it is one."""

    page: Path
    line: int
    lang: str
    text: str
    fragment: str | None = None

    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def parse_blocks(page: Path, text: str | None = None) -> list[Block]:
    """The fenced blocks of ``page`` (or of ``text``, as if it were that page's)."""
    lines = (page.read_text(encoding="utf-8") if text is None else text).splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        start, fence = i, opening["fence"]
        i += 1
        body = []
        while i < len(lines) and not lines[i].startswith(fence):
            body.append(lines[i])
            i += 1
        if i == len(lines):
            raise ValueError(f"{page}:{start + 1}: the block is never closed")
        before = start - 1
        while before >= 0 and not lines[before].strip():
            before -= 1
        marker = FRAGMENT.match(lines[before].strip()) if before >= 0 else None
        blocks.append(Block(page, start + 1, opening["lang"].lower(), "\n".join(body) + "\n",
                            None if marker is None else (marker["why"] or "fragment")))
        i += 1
    return blocks


def unfenced_code(page: Path, text: str | None = None) -> list[str]:
    """Lines of indented code blocks (4 spaces after a blank line, outside fences) that are a
    command or Python code, as ``page:line``: such code belongs in a fenced block."""
    lines = (page.read_text(encoding="utf-8") if text is None else text).splitlines()
    found, fence, indented = [], None, False
    for number, line in enumerate(lines, 1):
        opening = FENCE.match(line)
        if fence is None and opening:
            fence = opening["fence"]
        elif fence is not None and line.startswith(fence):
            fence = None
        elif fence is None:
            indented = line.startswith("    ") and (indented or number == 1
                                                    or not lines[number - 2].strip())
            if indented and CODE_START.match(line.strip()):
                found.append(f"{page.relative_to(ROOT)}:{number}")
    return found


# -- comparing printed text --------------------------------------------------------------------

def _tokens(text: str) -> list[tuple[str, str]]:
    return [(m.lastgroup if m.lastgroup != "cut" else "num", m["num"] or m.group())
            for m in TOKEN.finditer(text)]


def _unit(number: str) -> float:
    """One unit of the last digit written in ``number`` (0 for an integer: exact)."""
    mantissa, _, exponent = number.lower().partition("e")
    if "." not in mantissa and not exponent:
        return 0.0
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def _same(expected: tuple[str, str], actual: tuple[str, str]) -> bool:
    if expected[0] == "num":
        return (actual[0] == "num"
                and abs(float(actual[1]) - float(expected[1])) <= _unit(expected[1]) * (1 + 1e-9))
    return expected == actual


def matches(expected: str, actual: str) -> bool:
    """Whether the printed ``actual`` is what ``expected`` quotes (the module's rules)."""
    got = _tokens(actual)
    # reached[j]: the quoted tokens so far match the first j printed ones
    reached = [True] + [False] * len(got)
    for want in _tokens(expected):
        if want[0] == "ellipsis":
            reached = list(itertools.accumulate(reached, operator.or_))
        else:
            reached = [False] + [reached[j] and _same(want, got[j]) for j in range(len(got))]
    return reached[-1]


def _check_output(where: str, what: str, expected: str, actual: str) -> None:
    assert matches(expected, actual), (
        f"{where}: {what} prints\n{actual.rstrip()}\n--- but the page says ---\n"
        f"{expected.rstrip()}")


# -- running blocks ----------------------------------------------------------------------------

def _command(line: str, where: str) -> list[str] | None:
    """The arguments of a ``vibroimpact`` command line (``None`` for a comment); raises
    ``ValueError`` for anything else (another program, a pipe, a redirection)."""
    lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    words = list(lexer)
    if not words:
        return None
    if words[0] != "vibroimpact" or any(set(w) <= set("();<>|&") for w in words):
        raise ValueError(f"{where}: `{line}` is not a plain vibroimpact command; run only "
                         "those in a bash block, or mark the block <!-- fragment: why -->")
    return words[1:]


def _logical_lines(text: str) -> list[str]:
    joined, current = [], ""
    for raw in text.splitlines():
        current += raw.rstrip()
        if current.endswith("\\"):
            current = current[:-1] + " "
            continue
        joined.append(current)
        current = ""
    return joined + ([current] if current else [])


def _run_command(args: list[str], folder: Path, where: str) -> str:
    env = dict(os.environ, MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join([str(Path(vibroimpact.__file__).parents[1]),
                                           os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-m", "vibroimpact", *args], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert done.returncode == 0, (
        f"{where}: `vibroimpact {shlex.join(args)}` exits with {done.returncode}:\n"
        f"{done.stderr.strip()}")
    return done.stdout


def _expected_outputs(source: str) -> dict[int, str]:
    """The ``# -> TEXT`` comments of a Python block, by line."""
    found = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT and (m := EXPECTED.match(tok.string)):
            found[tok.start[0]] = m["text"]
    return found


def _run_python(block: Block, namespace: dict) -> str:
    tree = ast.parse(block.text, filename=block.where())
    expected = _expected_outputs(block.text)
    printed = io.StringIO()
    for statement in tree.body:
        where = f"{block.page.relative_to(ROOT)}:{block.line + statement.lineno}"
        out = io.StringIO()
        code = compile(ast.Module([statement], type_ignores=[]), where, "exec")
        with contextlib.redirect_stdout(out):
            exec(code, namespace)
        printed.write(out.getvalue())
        if statement.end_lineno in expected:
            _check_output(where, "this statement", expected.pop(statement.end_lineno),
                          out.getvalue())
    assert not expected, (f"{block.where()}: `# ->` inside a statement, not at its end "
                          f"(lines {sorted(expected)} of the block)")
    return printed.getvalue()


def _run_commands(block: Block, folder: Path) -> str:
    printed = []
    for offset, line in enumerate(_logical_lines(block.text)):
        args = _command(line, f"{block.where()}+{offset + 1}")
        if args is not None:
            printed.append(_run_command(args, folder, block.where()))
    return "".join(printed)


def _run_console(block: Block, folder: Path) -> str:
    """``$ vibroimpact ...`` lines run, each compared with the lines that follow it."""
    sessions: list[tuple[list[str], list[str]]] = []
    for line in _logical_lines(block.text):
        if line.startswith("$ "):
            args = _command(line[2:], block.where())
            assert args is not None, f"{block.where()}: an empty command"
            sessions.append((args, []))
        else:
            assert sessions, f"{block.where()}: output before the first `$ vibroimpact` line"
            sessions[-1][1].append(line)
    printed = []
    for args, expected in sessions:
        out = _run_command(args, folder, block.where())
        _check_output(block.where(), f"`vibroimpact {shlex.join(args)}`", "\n".join(expected),
                      out)
        printed.append(out)
    return "".join(printed)


def _check_toml(block: Block, folder: Path) -> None:
    try:
        table = tomllib.loads(block.text)
    except tomllib.TOMLDecodeError as exc:
        raise AssertionError(f"{block.where()}: not TOML: {exc}") from exc
    if block.fragment is not None:
        return
    assert {"structure", "solver"} <= set(table), (
        f"{block.where()}: a TOML block without [structure] and [solver] is not a model file; "
        "complete it or mark it <!-- fragment: why -->")
    path = folder / f"block_{block.line}.toml"
    path.write_text(block.text, encoding="utf-8")
    vibroimpact.load_model(path)


@dataclass
class PageRun:
    """The state a reader has while working through one page."""

    folder: Path
    namespace: dict = field(default_factory=lambda: {"__name__": "__docs__"})
    last_printed: str | None = None
    last_where: str = ""

    def run(self, block: Block) -> None:
        if block.lang == "output":
            assert block.fragment is None and self.last_printed is not None, (
                f"{block.where()}: an output block must follow the block it is the output of")
            _check_output(block.where(), f"the block at {self.last_where}", block.text,
                          self.last_printed)
            self.last_printed = None
            return
        self.last_printed = None
        if block.lang == "toml":
            _check_toml(block, self.folder)
        elif block.fragment is not None:
            if block.lang == "python":
                ast.parse(block.text, filename=block.where())
        elif block.lang == "python":
            self.last_printed = _run_python(block, self.namespace)
        elif block.lang in COMMAND_LANGS:
            self.last_printed = _run_commands(block, self.folder)
        elif block.lang == "console":
            self.last_printed = _run_console(block, self.folder)
        else:
            raise AssertionError(f"{block.where()}: a ```{block.lang or '(no language)'} block "
                                 "is not runnable; mark it <!-- fragment: why -->")
        self.last_where = block.where()


def _page_id(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize("page", PAGES, ids=_page_id)
def test_page_blocks_run_and_print_what_the_page_says(page: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    assert not unfenced_code(page), "commands or code in an indented block: fence them"
    reader = PageRun(tmp_path)
    try:
        for block in parse_blocks(page):
            reader.run(block)
    finally:
        import matplotlib.pyplot as plt

        plt.close("all")


# -- the checker itself ------------------------------------------------------------------------

@pytest.mark.parametrize(("expected", "actual", "ok"), [
    ("[0.00618624]", "[0.00618624]", True),
    ("[0.00618624]", "[0.006186245]", True),
    ("[0.00618624]", "[0.00618626]", False),
    ("[0.00618...]", "[0.00618624]", True),
    ("[0.00618...]", "[0.00620]", False),
    ("477.7 1038.6", "477.71179   1038.6034", True),
    ("477.7 1038.6", "477.9 1038.6", False),
    ("1.4e-4", "0.000145", True),
    ("1.4e-4", "2.55e-04", False),
    ("118 17", "118 17", True),
    ("118 17", "118 18", False),
    ("118", "118.0", True),
    ("steps 250000, ... s, energy", "steps 250000, 0.19 s, energy", True),
    ("a ... c", "a b\nb c", True),
    ("rigid 0", "elastic 0", False),
    ("x1 [rad]", "x1 [m]", False),
    ("first", "first and more", False),
])
def test_comparison_rules(expected: str, actual: str, ok: bool) -> None:
    assert matches(expected, actual) is ok


def test_unmarked_blocks_are_refused(tmp_path: Path) -> None:
    """A block that the test cannot run must be marked: a TOML snippet, a `text` block, a
    shell command that is not vibroimpact, an output block with nothing before it."""
    page = ROOT / "docs" / "new-page.md"
    for text in ("```toml\n[gaps.law]\nkind = \"rigid\"\n```\n",
                 "```text\nsome output\n```\n",
                 "```bash\npip install vibroimpact\n```\n",
                 "```bash\nvibroimpact run m.toml | head\n```\n",
                 "```output\n42\n```\n"):
        block, = parse_blocks(page, text)
        with pytest.raises((AssertionError, ValueError)):
            PageRun(tmp_path).run(block)
        marked, = parse_blocks(page, "<!-- fragment: a snippet -->\n\n" + text)
        assert marked.fragment == "a snippet"
        if marked.lang != "output":
            PageRun(tmp_path).run(marked)


def test_indented_code_is_found() -> None:
    page = ROOT / "docs" / "new-page.md"
    text = ("Run\n\n    vibroimpact run m.toml\n\nor\n\n    F = K δⁿ\n\n"
            "```bash\n    vibroimpact run m.toml\n```\n* a list\n    vibroimpact words\n")
    assert unfenced_code(page, text) == ["docs/new-page.md:3"]


def test_a_wrong_quote_fails(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    right, = parse_blocks(ROOT / "x.md", "```python\nprint(2 * 0.5)  # -> 1.0\n```\n")
    PageRun(tmp_path).run(right)
    wrong, = parse_blocks(ROOT / "x.md", "```python\nprint(2 * 0.6)  # -> 1.0\n```\n")
    with pytest.raises(AssertionError, match="prints"):
        PageRun(tmp_path).run(wrong)
    reader = PageRun(tmp_path)
    code, output = parse_blocks(ROOT / "x.md", "```python\nprint(3)\n```\n```output\n4\n```\n")
    reader.run(code)
    with pytest.raises(AssertionError, match="prints"):
        reader.run(output)
