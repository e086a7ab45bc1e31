"""The generated documentation pages are up to date with the code (issue 7: one page per contact
law with its e_eff against ce, the integrators page) and the hand-written pages name what
exists. Regenerate with ``python -m vibroimpact.docs``."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from vibroimpact.contact import LAWS
from vibroimpact.docs import integrators_page, law_page
from vibroimpact.plotting import KINDS

DOCS = Path(__file__).resolve().parents[1] / "docs"
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("kind", list(LAWS))
def test_every_law_has_its_generated_page(kind: str) -> None:
    page = DOCS / "laws" / f"{kind}.md"
    assert page.exists(), "run: python -m vibroimpact.docs"
    assert page.read_text(encoding="utf-8") == law_page(kind), (
        "stale; run: python -m vibroimpact.docs")


def test_no_page_for_a_law_that_does_not_exist() -> None:
    assert {p.stem for p in (DOCS / "laws").glob("*.md")} == set(LAWS)


def test_integrators_page_is_generated_from_methods() -> None:
    assert (DOCS / "integrators.md").read_text(encoding="utf-8") == integrators_page()


def test_getting_started_names_every_plot_kind_and_example() -> None:
    text = (DOCS / "getting-started.md").read_text(encoding="utf-8")
    for kind in KINDS:
        assert f"`{kind}`" in text
    for script in EXAMPLES.glob("*.py"):
        assert f"`{script.name}`" in text
    for page in ("model-file.md", "contact-laws.md", "integrators.md", "paper-cases.md"):
        assert f"]({page})" in text and (DOCS / page).exists()


ROOT = DOCS.parent

#: What points outside the repository: the design notes and the paper's text file the project
#: started from (neither is shipped; docs/conventions.md, docs/architecture.md and
#: docs/paper-cases.md hold what the repository relies on), and the development machine's paths.
OUTSIDE = re.compile(r"DESIGN\.md|shared[/\\]paper|\b0{3}_[0-9a-f]{16}\b|/wor[k]/")


def _tracked_text_files() -> dict[Path, str]:
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True,
                           text=True).stdout.split("\0")
    texts = {}
    for name in filter(None, names):
        path = ROOT / name
        if path.is_file():
            try:
                texts[path] = path.read_text(encoding="utf-8")
            except UnicodeDecodeError:  # a binary file mentions no path
                continue
    return texts


def test_no_tracked_file_points_outside_the_repository() -> None:
    texts = _tracked_text_files()
    assert ROOT / "README.md" in texts  # the listing is the repository's
    found = []
    for path, text in texts.items():
        depth = len(path.parent.relative_to(ROOT).parts)
        for number, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
            # a relative path that climbs above the repository from the file's folder
            for ups in re.findall(r"(?<![\w.])((?:\.\./)+)", line):
                if len(ups) // 3 > depth:
                    found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def _anchors(markdown: str) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"^```.*?^```", "", markdown, flags=re.M | re.S)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
            for h in re.findall(r"^#+ (.+)$", text, flags=re.M)}


def test_every_relative_markdown_link_resolves_inside_the_repository() -> None:
    broken = []
    for path, text in _tracked_text_files().items():
        if path.suffix != ".md":
            continue
        prose = re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", prose):
            if re.match(r"[a-z]+:", target):  # https:, mailto:
                continue
            file, _, anchor = target.partition("#")
            resolved = (path.parent / file).resolve() if file else path
            inside = resolved.is_relative_to(ROOT) and resolved.exists()
            if not inside or (anchor and resolved.suffix == ".md"
                              and anchor not in _anchors(resolved.read_text(encoding="utf-8"))):
                broken.append(f"{path.relative_to(ROOT)}: {target}")
    assert not broken, "\n".join(broken)
