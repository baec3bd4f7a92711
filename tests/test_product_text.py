"""The product text describes the product, not its history.

README.md, the docs, the scenes' comments, the package's source and the tests say what the code and
the method are and how to use them. What was tried and when belongs in the git history, so this
test fails, listing every file:line, wherever a phrase of FORBIDDEN appears (numbered rounds of past
work and the words that narrate attempts; "rounded" and "round-off" are not matched). Plain file
reading, no simulation.
"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

FORBIDDEN = [
    re.compile(pattern, re.IGNORECASE)
    for pattern in (
        r"\bsessions? \d+",
        r"\bexploration\b",
        r"tried, not kept",
        r"not tested \(older\)",
        r"\bround \d+\b",
    )
]


def product_files():
    """README.md, docs/**/*.md, scenes/*.toml, warpsph/**/*.py and tests/**/*.py, without this file."""
    files = [ROOT / "README.md"]
    files += sorted((ROOT / "docs").rglob("*.md"))
    files += sorted((ROOT / "scenes").glob("*.toml"))
    files += sorted((ROOT / "warpsph").rglob("*.py"))
    files += sorted((ROOT / "tests").rglob("*.py"))
    this = Path(__file__).resolve()
    return [path for path in files if path.is_file() and path.resolve() != this]


def test_scanned_files_exist():
    files = product_files()
    names = {path.relative_to(ROOT).parts[0] for path in files}
    assert {"README.md", "docs", "scenes", "warpsph", "tests"} <= names


def test_product_text_has_no_development_history():
    hits = []
    for path in product_files():
        text = path.read_text(encoding="utf-8")
        for number, line in enumerate(text.splitlines(), start=1):
            for pattern in FORBIDDEN:
                match = pattern.search(line)
                if match:
                    hits.append(f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r}: {line.strip()[:100]}")
    assert not hits, "development history in the product text (it belongs in git):\n" + "\n".join(hits)
