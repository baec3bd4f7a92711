"""The stability scoreboard's cases and table: each case runs one hard problem small enough for a
minute on one CPU thread and returns one :class:`Measure`; :func:`run_board` runs the cases asked for
under the same simulation options and writes their rows as JSON (docs/stability.md, *Scoreboard*)."""

from __future__ import annotations

import json
import math
import platform
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

import warp as wp

from warpsph.errors import SceneError, SimulationError
from warpsph.scene import Scene, Simulation
from warpsph.scene_types import convert_field
from warpsph.stages.energy import BALANCE_WARNING

COMMAND = "python -m warpsph.stability"
STABILISATION_KEYS = ("artificial_viscosity", "stress_filter", "velocity_filter", "hourglass_control",
                      "particle_shifting", "particle_velocity", "virtual_density")  # fmt: skip
"""The simulation keys that stabilise a run beyond the method itself (docs/scenes.md)."""
OPTION_SECTIONS = ("simulation", "pressure")
"""Sections of the scene whose keys ``--set`` may change in every case (the stabilisation's knobs)."""


@dataclass
class Measure:
    """What a case measured: one quantity against its limit (``below``: it holds when measured ≤ limit,
    otherwise when measured ≥ limit; a value that is not finite never holds), and the energy balance's
    error over the run as a fraction of the energy turned over (None where the run books none)."""

    quantity: str
    measured: float
    limit: float
    below: bool = True
    energy_error: float | None = None
    detail: str = ""
    """The other numbers a reader needs (steps, particles, secondary values)."""

    @property
    def holds(self) -> bool:
        m = float(self.measured)
        return math.isfinite(m) and (m <= self.limit if self.below else m >= self.limit)


@dataclass(frozen=True)
class Case:
    name: str
    title: str
    measure: Callable[[Mapping[str, object]], Measure | list[Measure]]
    """Runs the case with the simulation options given (``configure``) and returns its measure, or one
    per quantity it reports (a row each)."""


CASES: dict[str, Case] = {}


def case(name: str, title: str):
    """Register a scoreboard case under ``name``; the cases run in the order they are registered."""

    def register(measure):
        CASES[name] = Case(name, title, measure)
        return measure

    return register


def configure(scene: Scene, options: Mapping[str, object]) -> Scene:
    """``scene`` with the ``options`` ("simulation.<key>" or "pressure.<key>" → TOML value) set, as a
    scene file would set them, then validated."""
    for key, value in options.items():
        section, _, name = key.partition(".")
        if section not in OPTION_SECTIONS:
            raise SceneError(key, f"not a key the scoreboard sets; accepted: {' or '.join(OPTION_SECTIONS)}.<key>")
        owner = getattr(scene, section)
        if name not in owner.__dataclass_fields__:
            raise SceneError(key, f"unknown key; accepted: {', '.join(sorted(owner.__dataclass_fields__))}")
        setattr(owner, name, convert_field(type(owner), name, key, value))
    return scene.validate()


def without_stabilisation(scene: Scene) -> Scene:
    """``scene`` with every ``STABILISATION_KEYS`` key at its default (the scene is changed in place)."""
    defaults = Simulation()
    for key in STABILISATION_KEYS:
        setattr(scene.simulation, key, getattr(defaults, key))
    return scene


@dataclass
class Row:
    """One case's line of the table and JSON file."""

    case: str
    title: str
    quantity: str
    measured: float
    limit: float
    relation: str
    holds: bool
    energy_error: float | None
    energy_holds: bool | None
    seconds: float
    detail: str = ""


@dataclass
class Board:
    options: dict
    rows: list[Row] = field(default_factory=list)
    machine: str = field(default_factory=lambda: f"{platform.machine()}, Warp {wp.config.version}")

    def to_json(self) -> dict:
        return {"command": COMMAND, "options": self.options, "machine": self.machine,
                "energy_limit": BALANCE_WARNING, "rows": [asdict(r) for r in self.rows]}  # fmt: skip


def run_case(one: Case, options: Mapping[str, object]) -> list[Row]:
    """Run one case: a row per measure; a run that raises (a blow-up the guard stopped) is a row that
    does not hold."""
    start = time.perf_counter()
    try:
        measures = one.measure(options)
    except SimulationError as error:
        measures = Measure("runs to its end", math.nan, math.nan, detail=f"stopped: {error}")
    seconds = time.perf_counter() - start
    rows = []
    for m in measures if isinstance(measures, list) else [measures]:
        energy_holds = None if m.energy_error is None else bool(m.energy_error <= BALANCE_WARNING)
        rows.append(Row(one.name, one.title, m.quantity, float(m.measured), float(m.limit), "≤" if m.below else "≥",
                        m.holds, m.energy_error, energy_holds, seconds, m.detail))  # fmt: skip
    return rows


def run_board(names: list[str] | None = None, options: Mapping[str, object] | None = None,
              out: Path | None = None, echo: Callable[[str], None] | None = None) -> Board:
    """Run the cases ``names`` (all by default) with the simulation ``options``; write the board as
    JSON to ``out`` after each case (so a stopped run keeps its rows); ``echo`` gets each row's line."""
    board = Board(dict(options or {}))
    for name in names or list(CASES):
        rows = run_case(CASES[name], board.options)
        board.rows += rows
        for row in rows if echo is not None else []:
            echo(format_row(row))
        if out is not None:
            write_json(board, out)
    return board


def write_json(board: Board, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(path.suffix + ".part")
    partial.write_text(json.dumps(board.to_json(), indent=1, ensure_ascii=False) + "\n")
    partial.replace(path)


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:.4g}"


HEADER = ("case", "quantity", "measured", "limit", "holds", "energy error", "s")


def format_row(row: Row) -> str:
    energy = "–"
    if row.energy_error is not None:
        energy = f"{_number(row.energy_error)} ({'ok' if row.energy_holds else 'no'})"
    return " | ".join([row.case, row.quantity, _number(row.measured), f"{row.relation} {_number(row.limit)}",
                       "yes" if row.holds else "NO", energy, f"{row.seconds:.1f}"])  # fmt: skip


def markdown_table(board: Board) -> str:
    """The board as a Markdown table, one row per case."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += [f"| {format_row(r)} |" for r in board.rows]
    return "\n".join(lines)


def comparison_table(boards: list[dict], labels: list[str]) -> str:
    """Boards read from their JSON files side by side as a Markdown table: a row per case and quantity,
    a column per board with the measured value (✓ where it holds) and the energy balance's error."""
    keys = list(dict.fromkeys((r["case"], r["quantity"], r["relation"], r["limit"]) for b in boards for r in b["rows"]))
    found = [{(r["case"], r["quantity"]): r for r in b["rows"]} for b in boards]
    lines = ["| case | quantity | limit | " + " | ".join(labels) + " |", "|" + "---|" * (3 + len(labels))]
    for case_name, quantity, relation, limit in keys:
        cells = []
        for rows in found:
            r = rows.get((case_name, quantity))
            energy = "" if r is None or r["energy_error"] is None else f" ({_number(r['energy_error'])})"
            cells.append("" if r is None else f"{_number(r['measured'])}{' ✓' if r['holds'] else ''}{energy}")
        lines.append(f"| {case_name} | {quantity} | {relation} {_number(limit)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
