"""``python -m warpsph.stability``: run the stability scoreboard and write its rows as JSON."""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

from warpsph.errors import SceneError
from warpsph.stability import CASES, run_board
from warpsph.stability.board import HEADER, comparison_table, markdown_table

OUT = Path("runs/stability/board.json")


def option(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` with the value read as TOML (a bare word as a string)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE (e.g. simulation.artificial_viscosity=0.1), got {text!r}")
    try:
        return key.strip(), tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return key.strip(), value


def compare(paths: list[Path]) -> int:
    """Print the boards ``paths`` side by side, each column labelled by the options it ran with."""
    try:
        boards = [json.loads(p.read_text()) for p in paths]
    except (OSError, ValueError) as error:
        print(f"python -m warpsph.stability: error: --compare: {error}", file=sys.stderr)
        return 2
    labels = [", ".join(f"{k.partition('.')[2]} = {v}" for k, v in b["options"].items()) or "defaults" for b in boards]
    print(comparison_table(boards, labels))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m warpsph.stability", description=__doc__)
    parser.add_argument("--only", nargs="+", metavar="CASE", choices=list(CASES),
                        help=f"run these cases only (default: all): {', '.join(CASES)}")
    parser.add_argument("--set", dest="options", action="append", type=option, default=[], metavar="KEY=VALUE",
                        help="a simulation or pressure key set in every case, as in a scene file "
                             "(e.g. simulation.artificial_viscosity=0.1); repeat for more")
    parser.add_argument("--out", type=Path, default=OUT, help=f"the JSON file written (default: {OUT})")
    parser.add_argument("--compare", nargs="+", type=Path, metavar="JSON",
                        help="print the boards written before side by side (a Markdown table) and run nothing")
    args = parser.parse_args(argv)
    if args.compare:
        return compare(args.compare)
    print(" | ".join(HEADER), file=sys.stderr, flush=True)
    try:
        board = run_board(args.only, dict(args.options), args.out, echo=lambda line: print(line, file=sys.stderr,
                                                                                            flush=True))
    except SceneError as error:
        print(f"python -m warpsph.stability: error: {error}", file=sys.stderr)
        return 2
    print(markdown_table(board))
    failed = [r.case for r in board.rows if not r.holds]
    print(f"wrote {args.out}: {len(board.rows) - len(failed)} of {len(board.rows)} rows hold", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
