"""docs/scenes.md documents every scene key: each field of each scene dataclass is a row of its
section's key table (or, for the small tables without one, named in the section's text)."""

import dataclasses
import re
from pathlib import Path

import pytest

import warpsph.scene as S

DOC = (Path(__file__).resolve().parents[1] / "docs" / "scenes.md").read_text()
SECTIONS = {S.Simulation: "## `[simulation]`", S.Effects: "## `[effects]`", S.Material: "## `[materials.<name>]`",
            S.Body: "## `[[bodies]]`", S.Boundary: "## `[[boundaries]]`", S.Load: "## `[[loads]]`",
            S.Probe: "## `[[probes]]`", S.PressureSolver: "## `[pressure]`", S.Output: "## `[output]`",
            S.Phase: "## `[[phases]]`", S.Drainage: "### Drainage", S.TimeFunction: "### Time functions",
            S.Region: "### Regions", S.Reservoir: "## Groundwater flow"}  # fmt: skip
"""Each dataclass and the heading of its section."""


def section(heading: str) -> str:
    start = DOC.index(heading)
    level = heading.split(" ")[0]
    following = re.search(rf"^#{{1,{len(level)}}} ", DOC[start + len(heading):], flags=re.MULTILINE)
    return DOC[start: start + len(heading) + (following.start() if following else len(DOC))]


@pytest.mark.parametrize("cls", list(SECTIONS), ids=lambda c: c.__name__)
def test_every_field_is_documented_in_its_section(cls):
    text = section(SECTIONS[cls])
    missing = [f.name for f in dataclasses.fields(cls) if f"`{f.name}`" not in text and f.name != "source_text"]
    assert not missing, f"{SECTIONS[cls]} does not document {missing}"


def test_every_documented_simulation_key_exists():
    rows = re.findall(r"^\| `(\w+)` \|", section(SECTIONS[S.Simulation]), flags=re.MULTILINE)
    fields = {f.name for f in dataclasses.fields(S.Simulation)}
    assert rows and set(rows) <= fields, set(rows) - fields
