"""The validation manual's command (python -m warpsph.validation): it runs the cases asked for, writes
their figures, checks and index page, and exits non-zero when a check does not hold; the committed
manual (docs/validation) covers every case."""

import json
from pathlib import Path

from warpsph.validation import CASES, Check
from warpsph.validation.__main__ import main

ROOT = Path(__file__).resolve().parents[1]


def test_checks_hold_within_their_tolerance():
    assert Check("x", 1.02, 1.0, 0.03).holds and not Check("x", 1.04, 1.0, 0.03).holds
    assert Check("x", -0.004, 0.0, 0.005, relative=False).holds
    assert not Check("x", float("nan"), 0.0, 1.0, relative=False).holds


def test_the_command_writes_the_cases_it_runs(tmp_path, capsys):
    assert main(["--out", str(tmp_path), "--runs", str(tmp_path / "runs"), "--only", "undrained_limit", "wave_column",
                 "--quick"]) == 0  # fmt: skip
    index = (tmp_path / "index.md").read_text()
    records = json.loads((tmp_path / "results.json").read_text())
    assert [r["name"] for r in records] == ["wave_column", "undrained_limit"]  # in the manual's order
    for record in records:
        assert (tmp_path / record["figure"]).stat().st_size > 10_000
        assert f"({record['figure']})" in index and record["command"] in index
        assert record["checks"] and all(c["holds"] for c in record["checks"])
    assert "| front speed [m/s] |" in index
    assert main(["--out", str(tmp_path), "--runs", str(tmp_path / "runs"), "--only", "wave_column", "--quick"]) == 0
    again = json.loads((tmp_path / "results.json").read_text())  # one case rerun, the other kept
    assert [r["name"] for r in again] == ["wave_column", "undrained_limit"] and again[1] == records[1]
    assert (tmp_path / "index.md").read_text().count("## ") == 2


def test_the_committed_manual_covers_every_case():
    records = json.loads((ROOT / "docs" / "validation" / "results.json").read_text())
    assert [r["name"] for r in records] == list(CASES)
    for record in records:
        assert (ROOT / "docs" / "validation" / record["figure"]).is_file()


def test_a_check_that_does_not_hold_fails_the_command(tmp_path, monkeypatch, capsys):
    from warpsph.validation.report import Case, Outcome, figure

    def failing(context):
        fig, _ = figure()
        return Outcome("A case whose one check is off.", [Check("ratio", 2.0, 1.0, 0.1)], "none",
                       context.save(fig, "failing"))  # fmt: skip

    monkeypatch.setitem(CASES, "failing", Case("failing", "Failing", failing, 0.0))
    assert main(["--out", str(tmp_path), "--only", "failing"]) == 1
    assert "1 checks do not hold (failing: ratio)" in capsys.readouterr().err
    assert "| ratio | 2 | 1 | ± 0.1 | **no** |" in (tmp_path / "index.md").read_text()
