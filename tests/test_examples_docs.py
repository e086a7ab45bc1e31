"""The generated documentation pages are up to date with the code (issue 7: one page per contact
law with its e_eff against ce, the integrators page) and the hand-written pages name what
exists. Regenerate with ``python -m vibroimpact.report docs docs``."""

from __future__ import annotations

from pathlib import Path

import pytest
from vibroimpact.contact import LAWS
from vibroimpact.plotting import KINDS
from vibroimpact.report import integrators_page, law_page

DOCS = Path(__file__).resolve().parents[1] / "docs"
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("kind", list(LAWS))
def test_every_law_has_its_generated_page(kind: str) -> None:
    page = DOCS / "laws" / f"{kind}.md"
    assert page.exists(), "run: python -m vibroimpact.report docs docs"
    assert page.read_text(encoding="utf-8") == law_page(kind), (
        "stale; run: python -m vibroimpact.report docs docs")


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
