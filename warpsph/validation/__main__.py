"""``python -m warpsph.validation``: run the validation cases and write the manual's page and figures."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from warpsph.validation import CASES, write_manual
    from warpsph.validation.report import RUNS

    parser = argparse.ArgumentParser(prog="python -m warpsph.validation", description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/validation"),
                        help="directory of index.md, results.json and the figures (default: docs/validation)")
    parser.add_argument("--only", nargs="+", metavar="CASE", choices=list(CASES),
                        help=f"run these cases only (default: all): {', '.join(CASES)}")
    parser.add_argument("--runs", type=Path, default=RUNS,
                        help=f"directory of the cases' runs, one per case (default: {RUNS})")
    parser.add_argument("--device", default="cpu", help="Warp device of every run (default: cpu)")
    parser.add_argument("--quick", action="store_true",
                        help="coarsest resolutions only: checks the command, not the method")
    args = parser.parse_args(argv)
    results = write_manual(args.out, args.only, args.device, args.quick, args.runs,
                           echo=lambda line: print(line, file=sys.stderr, flush=True))
    failed = [f"{r.name}: {c['quantity']}" for r in results for c in r.checks if not c["holds"]]
    print(f"wrote {args.out / 'index.md'}: {len(results)} cases", file=sys.stderr)
    if failed:
        print(f"error: {len(failed)} checks do not hold ({'; '.join(failed)})", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
