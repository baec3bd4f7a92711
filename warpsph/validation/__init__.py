"""The validation manual: benchmark runs against closed forms, experiments and published values, each
drawn as a figure with its checks, run time and command (``python -m warpsph.validation --out DIR``;
docs/validation/index.md is its output)."""

from warpsph.validation.report import CASES, Check, Context, Outcome, write_manual
from warpsph.validation import waves, water, mandel, failure, safety  # noqa: F401  (register the cases, in order)

__all__ = ["CASES", "Check", "Context", "Outcome", "write_manual"]
