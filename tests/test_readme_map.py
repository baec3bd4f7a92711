"""The README's map of the package (*How it is built*) is the layout: every module and package of
warpsph is on it, every package's row names each of its modules, and everything it names exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "warpsph"
UNLISTED = {"__init__", "__main__"}


def rows() -> list[tuple[str, str]]:
    text = (ROOT / "README.md").read_text()
    table = text.split("## How it is built", 1)[1].split("\n\n", 2)[1]
    out = []
    for line in table.splitlines()[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        out.append((cells[0], " ".join(cells[1:])))
    return out


def test_every_module_and_package_is_on_the_map():
    files, packages = set(), {}
    for where, what in rows():
        names = re.findall(r"`([^`]+)`", where)
        if names and names[0].endswith("/"):
            packages[names[0]] = set(re.findall(r"`([A-Za-z_0-9]+)`", where + " " + what))
        else:
            files |= {Path(n).name for n in names}
    modules = {p.name for p in PACKAGE.glob("*.py") if p.stem not in UNLISTED}
    subpackages = {f"warpsph/{p.parent.name}/" for p in PACKAGE.glob("*/__init__.py")}
    assert sorted(modules - files) == [], "modules missing from the README's map"
    assert sorted(files - modules) == [], "files on the README's map that do not exist"
    assert sorted(subpackages - set(packages)) == [], "packages missing from the README's map"
    assert sorted(set(packages) - subpackages) == [], "packages on the README's map that do not exist"
    for package, named in packages.items():
        stems = {p.stem for p in (ROOT / package).glob("*.py") if p.stem not in UNLISTED}
        assert sorted(stems - named) == [], f"modules of {package} its row does not name"
