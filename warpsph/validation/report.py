"""The validation manual's cases and its page: each case runs benchmarks, draws one figure and states
its checks; :func:`write_manual` runs the cases asked for and writes ``index.md`` with their figures
(docs/validation/index.md explains how to read it)."""

from __future__ import annotations

import json
import math
import platform
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

COMMAND = "python -m warpsph.validation"
RUNS = Path("runs/validation")
"""Where the cases' runs write their results by default, one directory per case."""
SCENES = Path(__file__).resolve().parents[2] / "scenes"
"""The shipped scenes, beside the package in a source checkout."""


def shipped_scene(name: str):
    """The shipped scene ``name`` (scenes/<name>.toml), parsed, without its USD output."""
    from warpsph.scene_toml import load_scene

    scene = load_scene(SCENES / f"{name}.toml")
    scene.output.usd = False
    return scene


@dataclass
class Check:
    """A measured quantity against its reference: it holds when |measured − reference| ≤ tolerance
    (``relative``: tolerance × |reference|)."""

    quantity: str
    measured: float
    reference: float
    tolerance: float
    relative: bool = True
    source: str = ""
    """Where the reference comes from (a closed form, a paper, an experiment)."""

    def __post_init__(self):
        self.measured, self.reference = float(self.measured), float(self.reference)
        self.tolerance = float(self.tolerance)

    @property
    def allowed(self) -> float:
        return self.tolerance * abs(self.reference) if self.relative else self.tolerance

    @property
    def holds(self) -> bool:
        return bool(math.isfinite(self.measured) and abs(self.measured - self.reference) <= self.allowed)


@dataclass
class Outcome:
    """What a case returns: what it compares, its checks, the resolution it ran at and its figure."""

    summary: str
    """A paragraph: what is run, what it is compared with and what is seen."""
    checks: list[Check]
    resolution: str
    """Spacing, particles and steps of the runs."""
    figure: str
    """File name of the figure, in the output directory."""


@dataclass
class CaseResult:
    name: str
    title: str
    outcome: Outcome
    seconds: float
    command: str
    checks: list[dict] = field(default_factory=list)
    """The outcome's checks as records, each with whether it holds."""

    @property
    def held(self) -> int:
        return sum(c["holds"] for c in self.checks)

    @property
    def anchor(self) -> str:
        return self.name.replace("_", "-")


@dataclass
class Context:
    """What a case is given: the manual's directory, the Warp device, whether to run coarse (``quick``:
    the coarsest resolutions only, for a check of the command itself) and the runs' directory."""

    out: Path
    device: str = "cpu"
    quick: bool = False
    runs: Path = RUNS
    """Where the cases' runs write their results, one directory per case (not the manual's directory)."""

    def save(self, fig, name: str) -> str:
        """Write a Matplotlib figure as ``name``.png in the output directory; its file name."""
        path = self.out / f"{name}.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        return path.name


@dataclass
class Case:
    name: str
    title: str
    run: Callable[[Context], Outcome]
    minutes: float
    """Rough run time on a 2-core CPU [min], at the manual's resolutions."""


CASES: dict[str, Case] = {}


def case(name: str, title: str, minutes: float):
    """Register ``fn(context) -> Outcome`` as the validation case ``name``."""

    def register(fn: Callable[[Context], Outcome]):
        CASES[name] = Case(name, title, fn, minutes)
        return fn

    return register


def figure(*shape: int, width: float = 10.0, height: float = 4.0):
    """A Matplotlib figure with a grid of axes (no pyplot: no display, no global state)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    axes = fig.subplots(*shape) if shape else fig.subplots()
    return fig, axes


def convergence_plot(axes, spacings, errors, order: float, label: str) -> None:
    """``errors`` against ``spacings`` on log axes, with the line of the expected ``order`` through the
    coarsest point; the spacings as ticks."""
    from matplotlib.ticker import FixedLocator, NullLocator

    axes.loglog(spacings, errors, "o-", label=label)
    axes.loglog(spacings, [errors[0] * (dx / spacings[0]) ** order for dx in spacings], "k:",
                label=f"order {order:g}")  # fmt: skip
    axes.xaxis.set_major_locator(FixedLocator(spacings))
    axes.xaxis.set_minor_locator(NullLocator())
    axes.set_xticklabels([f"{dx:g}" for dx in spacings])
    axes.set(xlabel="Δx [m]", title="under refinement")
    axes.legend()


def run_case(item: Case, context: Context) -> CaseResult:
    start = time.perf_counter()
    outcome = item.run(context)
    seconds = time.perf_counter() - start
    command = f"{COMMAND} --out {context.out} --only {item.name}" + (" --quick" if context.quick else "")
    return CaseResult(item.name, item.title, outcome, seconds, command,
                      [asdict(c) | {"holds": c.holds} for c in outcome.checks])  # fmt: skip


def _number(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else str(x)


def _check_rows(checks: list[Check]) -> list[str]:
    rows = ["| quantity | measured | reference | allowed | holds | reference from |", "|---|---:|---:|---:|:-:|---|"]
    for c in checks:
        quantity = c.quantity.replace("|", "\\|")  # a bar inside a table cell
        rows.append(f"| {quantity} | {_number(c.measured)} | {_number(c.reference)} | ± {_number(c.allowed)} | "
                    f"{'yes' if c.holds else '**no**'} | {c.source} |")  # fmt: skip
    return rows


def _machine() -> str:
    import warp as wp

    from warpsph.version import __version__

    return f"warpsph {__version__}, Warp {wp.config.version}, Python {platform.python_version()}, " \
           f"{platform.machine()} ({platform.processor() or platform.system()})"  # fmt: skip


def write_manual(out: Path, names: list[str] | None = None, device: str = "cpu", quick: bool = False,
                 runs: Path = RUNS, echo: Callable[[str], None] = print) -> list[CaseResult]:
    """Run the cases ``names`` (all by default), their runs' results in ``runs``, and write their figures,
    ``results.json`` and ``index.md`` into ``out``, keeping there the other cases an earlier run wrote;
    the results of the cases run."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    context = Context(out, device, quick, Path(runs))
    results = []
    for name in names or list(CASES):
        echo(f"{name}: {CASES[name].title} ...")
        result = run_case(CASES[name], context)
        echo(f"{name}: {result.held} of {len(result.checks)} checks hold ({result.seconds:.0f} s)")
        results.append(result)
    kept = {r.name: r for r in _read_results(out) if r.name in CASES} if names else {}
    kept.update((r.name, r) for r in results)
    manual = [kept[name] for name in CASES if name in kept]
    _write_index(out, manual, device, quick)
    (out / "results.json").write_text(json.dumps(
        [{"name": r.name, "title": r.title, "seconds": r.seconds, "command": r.command, "resolution":
          r.outcome.resolution, "figure": r.outcome.figure, "summary": r.outcome.summary, "checks": r.checks}
         for r in manual], indent=1))  # fmt: skip
    return results


def _read_results(out: Path) -> list[CaseResult]:
    """The cases of the manual in ``out`` (its ``results.json``; none where it has none)."""
    path = out / "results.json"
    if not path.is_file():
        return []
    results = []
    for record in json.loads(path.read_text()):
        checks = [Check(**{k: v for k, v in c.items() if k != "holds"}) for c in record["checks"]]
        outcome = Outcome(record["summary"], checks, record["resolution"], record["figure"])
        results.append(CaseResult(record["name"], record["title"], outcome, record["seconds"], record["command"],
                                  record["checks"]))  # fmt: skip
    return results


def _write_index(out: Path, results: list[CaseResult], device: str, quick: bool) -> None:
    whole = f"{COMMAND} --out {out}" + (" --quick" if quick else "")
    lines = [
        "# Validation manual",
        "",
        "Each section runs one benchmark with the shipped solver and its defaults, draws it against its "
        "reference (a closed form, an experiment or a published solution) and lists the checks with the "
        "tolerance each is held to. Every figure states its resolution, its run time and the command that "
        "redraws it. This page and its figures are written by",
        "",
        f"```sh\n{whole}\n```",
        "",
        f"on {_machine()}, device `{device}`" + (", at the coarse resolutions of `--quick`" if quick else "") + ". "
        "The theory behind each number is in [the method](../method.md); how accuracy trades against run "
        "time is in [Accuracy and what it costs](../accuracy.md).",
        "",
        "| case | checks holding | run time |",
        "|---|---|---:|",
    ]  # fmt: skip
    for r in results:
        lines.append(f"| [{r.title}](#{r.anchor}) | {r.held} of {len(r.checks)} | {r.seconds:.0f} s |")
    for r in results:
        lines += ["", f"## {r.title} {{#{r.anchor}}}", "", r.outcome.summary, "",
                  f"![{r.title}]({r.outcome.figure})", "", *_check_rows(r.outcome.checks), "",
                  f"*{r.outcome.resolution}; {r.seconds:.0f} s on `{device}`; `{r.command}`*"]  # fmt: skip
    (out / "index.md").write_text("\n".join(lines) + "\n")


def run_scene(context: Context, case_name: str, label: str, scene, end_time: float | None = None):
    """Run ``scene`` on the context's device into runs/<case_name>/<label> of its output directory
    (overwriting an earlier run there); (its results, its run summary)."""
    from warpsph.io import load_results
    from warpsph.runner import Run

    out = context.runs / case_name / label
    summary = Run(scene, out, device=context.device, end_time=end_time, overwrite=True).run()
    return load_results(out / "results.h5"), summary
