"""The manual builds as a site (mkdocs.yml, strict): a broken link or anchor, a page missing from the
navigation, or an API reference entry that names nothing fails the build."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_manual_builds_without_a_warning(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    for page in ("index.html", "scenes/index.html", "method/index.html", "reference/scene/index.html"):
        assert (tmp_path / page).is_file(), page
    assert "One stage of a staged analysis" in (tmp_path / "reference/scene/index.html").read_text()
