"""What every benchmark record carries: the machine, the timings of a row, Markdown tables, the JSON file."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path

import warp as wp

from warpsph.version import __version__


def cpu_model() -> str:
    """The CPU's model name (Linux /proc/cpuinfo), else platform.processor()."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def machine_record(device: str) -> dict:
    """Where the benchmark ran."""
    return {
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "warp_version": wp.config.version,
        "warpsph_version": __version__,
        "device": device,
        "device_name": wp.get_device(device).name,
    }


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table with right-aligned, padded columns."""
    widths = [max(len(c) for c in col) for col in zip(header, *rows)]

    def line(cells) -> str:
        return "| " + " | ".join(c.rjust(w) for c, w in zip(cells, widths)) + " |"

    return "\n".join([line(header), "|" + "|".join("-" * (w + 1) + ":" for w in widths) + "|", *map(line, rows)])


def timing_fields(particles: int, steps: int, dt: float, build_s: float, compile_s: float, wall: float) -> dict:
    """The timing entries every benchmark row carries (times in s)."""
    return {
        "time_step": dt,
        "steps": steps,
        "build_seconds": build_s,
        "compile_seconds": compile_s,
        "wall_seconds": wall,
        "seconds_per_step": wall / steps,
        "particle_steps_per_second": particles * steps / wall,
    }


def write_record(path, record: dict) -> None:
    """Write a benchmark record as JSON to ``path`` and say so."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=2, default=str))
    print(f"\nwrote {path}")
