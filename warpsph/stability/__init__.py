"""The stability scoreboard: a fixed list of hard cases, each a minute on one CPU thread, one row per
measured quantity against its limit with the energy balance's closure (``python -m warpsph.stability``;
docs/stability.md, *Scoreboard*)."""

from warpsph.stability.board import CASES, Board, Measure, case, configure, run_board
from warpsph.stability import elastic, failure, water  # noqa: F401  (register the cases, in order)

__all__ = ["CASES", "Board", "Measure", "case", "configure", "run_board"]
