"""Side by side with PySPH: ``python -m warpsph.bench --peer pysph`` (docs/performance.md, *Against PySPH*).

Each round runs, for every case (dimension, size, CPU threads), warpsph's dry two-set step and
PySPH's elastic-solid scheme on the same block, one after the other, each in a process of its
own (``python -m warpsph.bench`` and :mod:`warpsph.bench.peer_pysph`), so that both see the same machine
state; each process reports its steady-state throughput (compilation and set-up excluded), its
neighbour pairs per step and its memory. It prints the per-round ratios and their median and
writes a JSON record. PySPH is not a dependency: it is installed on demand into a virtual
environment of its own (``PEER_ENV``), never in CI.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from warpsph.bench.record import markdown_table

PEER_VERSION = "1.0b2"
PEER_ENV = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "warpsph" / f"pysph-{PEER_VERSION}"
"""Where PySPH is installed on demand."""
PEER_INSTALL = (
    ["numpy", "cython<3.1", "mako", "setuptools", "wheel"],
    ["--no-build-isolation", "cyarray", "compyle", "pytools", "beaker"],
    ["--no-build-isolation", f"pysph=={PEER_VERSION}"],
)
"""pip installs, in order: PySPH's build needs Cython and its Cython-level dependencies installed
before it builds, without build isolation."""
PEER_SIZES = {2: 16384, 3: 32768}
"""Default block per dimension: 128 × 128 and 32 × 32 × 32 particles."""
PEER_STEPS = {2: 100, 3: 30}
"""Timed steps per process at the default sizes (a few seconds each on one core)."""
PEER_SCRIPT = Path(__file__).with_name("peer_pysph.py")


def has_pysph(python: str) -> bool:
    return subprocess.run([python, "-c", "import pysph"], capture_output=True).returncode == 0


def peer_python(requested: str | None) -> str:
    """The Python that runs PySPH: ``requested``, else this one if it has PySPH, else ``PEER_ENV``'s,
    installing PySPH there first if it is not yet."""
    if requested:
        if not has_pysph(requested):
            raise SystemExit(f"warpsph.bench: error: --peer-python {requested}: cannot import pysph")
        return requested
    if has_pysph(sys.executable):
        return sys.executable
    python = PEER_ENV / "bin" / "python"
    if not (python.exists() and has_pysph(str(python))):
        print(f"installing PySPH {PEER_VERSION} into {PEER_ENV} (once; it compiles for a few minutes)", flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(PEER_ENV)], check=True)
        for packages in PEER_INSTALL:
            subprocess.run([str(python), "-m", "pip", "install", "-q", *packages], check=True)
    return str(python)


def last_json_line(text: str) -> dict:
    return json.loads([line for line in text.splitlines() if line.startswith("{")][-1])


def run_warpsph(dim: int, particles: int, steps: int, threads: int) -> dict:
    """One warpsph measurement in a process of its own: its record's single result."""
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "warpsph.json"
        command = [sys.executable, "-m", "warpsph.bench", "--dim", str(dim), "--sizes", str(particles),
                   "--steps", str(steps), "--threads", str(threads), "--json", str(record)]  # fmt: skip
        subprocess.run(command, check=True, capture_output=True, text=True)
        return json.loads(record.read_text())["results"][0]


def run_pysph(python: str, dim: int, particles: int, steps: int, threads: int) -> dict:
    """One PySPH measurement in a process of its own."""
    command = [python, str(PEER_SCRIPT), "--dim", str(dim), "--particles", str(particles), "--steps", str(steps),
               "--threads", str(threads)]  # fmt: skip
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    return last_json_line(done.stdout)


def ratios(ours: dict, peer: dict) -> dict:
    """warpsph over PySPH: throughput per particle-step and per neighbour pair; memory per particle."""
    return {
        "particle_steps": ours["particle_steps_per_second"] / peer["particle_steps_per_second"],
        "pair_interactions": ours["neighbour_interactions_per_second"] / peer["neighbour_interactions_per_second"],
        "process_memory": ours["max_rss_bytes"] / peer["max_rss_bytes"],
    }


def compare(cases: list[tuple[int, int, int]], rounds: int, python: str | None, steps: int | None) -> dict:
    """Interleaved rounds over ``cases`` (dim, particles, threads); the record."""
    python = peer_python(python)
    for dim, particles, threads in cases:  # compile both sides' kernels once, outside the rounds
        run_warpsph(dim, particles, 1, threads)
        run_pysph(python, dim, particles, 1, threads)
    rows = []
    for r in range(rounds):
        for dim, particles, threads in cases:
            n_steps = steps or PEER_STEPS[dim]
            ours = run_warpsph(dim, particles, n_steps, threads)
            peer = run_pysph(python, dim, particles, n_steps, threads)
            row = {"round": r, "dim": dim, "threads": threads, "warpsph": ours, "pysph": peer,
                   "ratio": ratios(ours, peer)}  # fmt: skip
            rows.append(row)
            print(f"  round {r + 1}, {dim}D {ours['particles']} particles, {threads} thread(s): warpsph "
                  f"{ours['particle_steps_per_second']:.3g}, PySPH {peer['particle_steps_per_second']:.3g} "
                  f"particle-steps/s ({row['ratio']['particle_steps']:.2f}x)", flush=True)  # fmt: skip
    return {"cases": cases, "rounds": rounds, "rows": rows}


def summary_table(record: dict) -> str:
    """One row per case: medians over the rounds."""

    lines = []
    for dim, particles, threads in record["cases"]:
        rows = [r for r in record["rows"] if (r["dim"], r["threads"]) == (dim, threads)
                and r["warpsph"]["requested"] == particles]  # fmt: skip
        med = lambda f: statistics.median(f(r) for r in rows)  # noqa: E731
        lines.append([
            f"{dim}D", str(rows[0]["warpsph"]["particles"]), str(threads),
            f"{med(lambda r: r['warpsph']['particle_steps_per_second']):.3g}",
            f"{med(lambda r: r['pysph']['particle_steps_per_second']):.3g}",
            f"{med(lambda r: r['ratio']['particle_steps']):.2f}",
            f"{med(lambda r: r['warpsph']['neighbour_pairs_per_step']) / rows[0]['warpsph']['particles']:.1f}",
            f"{med(lambda r: r['pysph']['neighbour_pairs_per_step']) / rows[0]['pysph']['particles']:.1f}",
            f"{med(lambda r: r['ratio']['pair_interactions']):.2f}",
            f"{med(lambda r: r['warpsph']['memory_bytes_per_particle']):.0f}",
            f"{med(lambda r: r['warpsph']['max_rss_bytes']) / 2**20:.0f}",
            f"{med(lambda r: r['pysph']['max_rss_bytes']) / 2**20:.0f}",
        ])
    header = ["dim", "particles", "threads", "warpsph p-steps/s", "PySPH p-steps/s", "ratio",
              "warpsph pairs/particle", "PySPH pairs/particle", "pair ratio", "warpsph bytes/particle",
              "warpsph RSS MiB", "PySPH RSS MiB"]  # fmt: skip
    return markdown_table(header, lines)
