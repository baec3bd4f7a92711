"""Factor-of-safety cases: strength reduction (the ``safety`` phase, docs/scenes.md *Phases*) against
Griffiths & Lane's 2:1 slope and Taylor's chart for an undrained slope; each figure draws the mechanism
of the weakest trial that failed and every trial of the search."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import warpsph
from warpsph.io.results import TRIAL_COLUMNS
from warpsph.validation.report import Check, Context, Outcome, case, figure, shipped_scene

GRIFFITHS_LANE, BISHOP = 1.4, 1.38
"""The 2:1 slope's factor of safety by Griffiths & Lane's finite elements and by Bishop and Morgenstern's charts."""
SLOPE_OUTLINE = [(0, 0), (44, 0), (44, 12), (32, 12), (12, 2), (0, 2)]
STRENGTH_REDUCTION_TO_BISHOP = 0.05
"""How far a strength-reduction factor may lie from limit equilibrium on a homogeneous slope that fails
on a circle (docs/scenes.md, *Limit equilibrium*)."""

G = 9.81
CU, RHO, H = 12e3, 2000.0, 2.0
TAYLOR = CU / (0.191 * RHO * G * H)
"""The undrained slope's factor of safety by Taylor's chart (N_s = 0.191 at 60°), 1.601."""
BASE, TOE, WIDTH = 1.0, 2.0, 8.0  # the toe's level, its x and the ground's width [m]
CREST = TOE + H / math.tan(math.radians(60.0))
SLOPE = [(0, 0), (WIDTH, 0), (WIDTH, BASE + H), (CREST, BASE + H), (TOE, BASE), (0, BASE)]


def strength_reduction_phases(max_steps: int, factor_tolerance: float):
    """The K0 procedure, gravity loading to equilibrium, then a safety phase whose trials are capped at
    ``max_steps`` and searched to ± ``factor_tolerance``."""
    from warpsph.scene import Phase

    return [Phase("initial", kind="k0"), Phase("gravity", kind="equilibrium"),
            Phase("safety", kind="safety", max_steps=max_steps, factor_tolerance=factor_tolerance)]  # fmt: skip


def undrained_clay(name: str, vertices, dx: float, phases, cohesion: float, density: float = 2000.0):
    """A scene of undrained clay in total stress (dry, von Mises with c_u = ``cohesion`` [Pa], ρ = ``density``
    [kg/m³], E = 20 MPa, ν = 0.3, plasticity on) filling the polygon ``vertices`` [m] under gravity: a fixed
    base at y = 0, slip sides at the polygon's smallest and largest x, the given ``phases``; frames hold
    velocity, stress and displacement (no USD or XDMF)."""
    from warpsph import Body, Boundary, Material, Scene, Simulation

    xs = [x for x, _ in vertices]
    clay = Material("clay", model="viscoplastic", density=density, youngs_modulus=2e7, poisson_ratio=0.3,
                    yield_function="von_mises", cohesion=cohesion)  # fmt: skip
    scene = Scene(name=name, simulation=Simulation(dim=2, dx=dx, end_time=1.0, gravity=(0.0, -G, 0.0)),
                  materials={"clay": clay}, bodies=[Body("ground", "clay", shape="polygon", vertices=vertices)],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", min(xs), "min"),
                              Boundary("right", "slip", "x", max(xs), "max")],
                  phases=phases)  # fmt: skip
    scene.effects = dataclasses.replace(scene.effects, plasticity=True)
    _lean_output(scene)
    return scene.validate()


def _lean_output(scene) -> None:
    scene.output.usd = scene.output.xdmf = False
    scene.output.frame_interval = 1e3
    scene.output.fields = ["velocity", "stress", "displacement"]


@dataclass
class Search:
    """A run's strength-reduction search and the last frame of its weakest failing trial."""

    fos: float
    outcome: str
    tolerance: float
    max_steps: int
    trials: np.ndarray
    """(T, 7): the rows of ``/phases/trials/<name>`` (docs/output.md): factor, outcome (1 stood, 0 failed, −1
    undecided), final unbalanced-force ratio, steps, largest displacement [m], kinetic energy, why."""
    factor: float
    """The weakest failing trial's factor (nan: none failed)."""
    position: np.ndarray
    """That trial's last positions (N, 3) [m]."""
    displacement: np.ndarray
    particles: int
    steps: int
    dx: float
    bishop: float
    """Bishop's factor on the phase's particles at its start (nan: none)."""

    @property
    def moved(self) -> np.ndarray:
        return np.linalg.norm(self.displacement, axis=1)

    @property
    def resolution(self) -> str:
        return (f"Δx = {self.dx:g} m, {self.particles} particles; {len(self.trials)} trials capped at "
                f"{self.max_steps} steps, searched to ± {self.tolerance:g}; {self.steps} steps in all")  # fmt: skip


def search(scene, out: Path, device: str) -> Search:
    """Run ``scene`` (its last phase a safety phase) into ``out``, replacing an earlier run there."""
    out.mkdir(parents=True, exist_ok=True)
    summary = warpsph.run_scene(scene, out, device=device, overwrite=True)
    results = warpsph.load_results(out / "results.h5")
    phase = scene.phases[-1]
    trials = np.asarray(summary.phases[-1]["trials"], dtype=float).reshape(-1, TRIAL_COLUMNS)
    failed = trials[trials[:, 1] == 0, 0]
    factor = failed.min() if len(failed) else math.nan
    k = next((k for k in range(len(results)) if results.frame_attrs(k).get("factor") == factor), -1)
    frame = results.frame(k)
    record = summary.phases[-1]
    bishop = (record.get("limit_equilibrium") or [math.nan])[0]
    return Search(float(record["criterion"]), record["outcome"], phase.factor_tolerance, phase.max_steps, trials,
                  factor, frame["position"], frame["displacement"], summary.particles, summary.final_step,
                  scene.simulation.dx, float(bishop))  # fmt: skip


def draw(context: Context, name: str, found: Search, outline, reference: float, tolerance: float,
         label: str, height: float) -> str:  # fmt: skip
    """The figure of a search: left its weakest failing trial's particles coloured by displacement over the
    ground's ``outline``, right every trial's factor in order against ``reference`` ± ``tolerance``."""
    from matplotlib.collections import EllipseCollection

    fig, (left, right) = figure(1, 2, width=12.0, height=height)
    left.get_gridspec().set_width_ratios([2.4, 1.0])
    fig.subplots_adjust(wspace=0.45)
    xy = np.asarray(outline + outline[:1], dtype=float)
    left.plot(xy[:, 0], xy[:, 1], color="k", lw=0.8, ls="--", zorder=3, label="ground at the start")
    order = np.argsort(found.moved)
    dots = EllipseCollection(found.dx, found.dx, 0.0, units="xy", offsets=found.position[order, :2],
                             offset_transform=left.transData, cmap="viridis")
    dots.set_array(found.moved[order])
    left.add_collection(dots)
    fig.colorbar(dots, cax=left.inset_axes([1.02, 0.0, 0.02, 1.0]), label="|displacement| [m]")
    left.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title=f"mechanism: trial F = {found.factor:.3f} (failed)")
    left.legend(loc="upper left", fontsize=8, frameon=False)
    n = np.arange(1, len(found.trials) + 1)
    stood, failed = found.trials[:, 1] == 1, found.trials[:, 1] == 0
    right.axhspan(reference * (1 - tolerance), reference * (1 + tolerance), color="tab:blue", alpha=0.15,
                  label=f"{label}, {reference:.4g} ± {tolerance:.0%}")  # fmt: skip
    right.axhline(reference, color="tab:blue", lw=1)
    right.axhline(found.fos, color="k", ls="--", lw=1, label=f"factor of safety found, {found.fos:.3f}")
    right.plot(n, found.trials[:, 0], color="0.7", lw=0.8, zorder=1)
    right.scatter(n[stood], found.trials[stood, 0], marker="o", color="tab:green", label="stood", zorder=2)
    right.scatter(n[failed], found.trials[failed, 0], marker="x", color="tab:red", label="failed", zorder=2)
    undecided = ~(stood | failed)
    if undecided.any():
        right.scatter(n[undecided], found.trials[undecided, 0], marker="s", color="tab:orange", label="undecided",
                      zorder=2)  # fmt: skip
    right.set(xlabel="trial", ylabel="trial factor F [-]", title="strength-reduction search", xticks=n)
    right.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return context.save(fig, name)


@case("slope_factor_of_safety", "Factor of safety of a 2:1 slope (Griffiths & Lane)", minutes=3.5)
def slope_factor_of_safety(context: Context) -> Outcome:
    scene = shipped_scene("slope_fos")
    scene.phases = [p for p in scene.phases if p.kind != "dynamic"]
    if context.quick:
        scene.phases[-1].factor_tolerance = 0.05
    _lean_output(scene)
    found = search(scene.validate(), context.runs / "slope_factor_of_safety", context.device)
    png = draw(context, "slope_factor_of_safety", found, SLOPE_OUTLINE, BISHOP, STRENGTH_REDUCTION_TO_BISHOP,
               "Bishop & Morgenstern", height=3.6)  # fmt: skip
    sliding = found.position[found.moved > 0.5 * found.moved.max(), 0]
    summary = (
        "Griffiths & Lane's (1999, example 1) homogeneous slope, H = 10 m at 2:1, φ′ = 20°, c′ = 0.05 γH = 10 kPa, "
        "ψ = 0, on 2 m of the same soil over a rough base (scenes/slope_fos.toml without its run-out): the K0 "
        "procedure and gravity equilibrium, then strength reduction, c′ and tan φ′ divided by trial factors. "
        f"The search ({found.outcome}) brackets the factor of safety at {found.fos:.3f} ± {found.tolerance:g} in "
        f"{len(found.trials)} trials, {found.fos / BISHOP - 1:+.1%} from Bishop and Morgenstern's 1.38 and "
        f"{found.fos / GRIFFITHS_LANE - 1:+.1%} from the finite elements' 1.4; Bishop's method on the phase's own "
        f"particles gives {found.bishop:.3f} ({found.fos / found.bishop - 1:+.1%}). In the weakest trial that failed "
        f"(F = {found.factor:.3f}) the particles that moved more than half the most reach from x = "
        f"{sliding.min():.1f} m to {sliding.max():.1f} m (the toe is at x = 12 m, the crest at 32 m)."
    )
    checks = [Check("factor of safety", found.fos, BISHOP, STRENGTH_REDUCTION_TO_BISHOP,
                    source="Bishop & Morgenstern's charts (Griffiths & Lane 1999)"),
              Check("Bishop's factor on the particles", found.bishop, BISHOP, 0.03,
                    source="Bishop & Morgenstern's charts (Griffiths & Lane 1999)")]  # fmt: skip
    return Outcome(summary, checks, found.resolution, png)


@case("taylor_slope", "Undrained slope against Taylor's chart", minutes=4.5)
def taylor_slope(context: Context) -> Outcome:
    dx, max_steps, factor_tolerance, tolerance = (0.25, 8000, 0.05, 0.06) if context.quick else (0.2, 15000, 0.02, 0.03)
    found = search(undrained_clay("taylor", SLOPE, dx, strength_reduction_phases(max_steps, factor_tolerance), CU,
                                  RHO), context.runs / "taylor_slope", context.device)
    png = draw(context, "taylor_slope", found, SLOPE, TAYLOR, tolerance, "Taylor's chart", height=3.4)
    start, moved = found.position - found.displacement, found.moved
    face = np.array([CREST - TOE, H]) / math.hypot(CREST - TOE, H)
    at = start[np.argmax(moved), :2] - (TOE, BASE)
    off_face, height = float(abs(at[0] * face[1] - at[1] * face[0])), float(at[1])
    behind = float(moved[start[:, 0] > CREST + 2 * H].max() / moved.max())
    summary = (
        "A 60° slope H = 2 m high in undrained clay (φ = 0, c_u = 12 kPa, ρ = 2000 kg/m³, in total stress) on 1 m "
        "of the same clay over a rough base (depth factor D = 1.5): equilibrium, then strength reduction of c_u. "
        "Taylor's chart puts slopes steeper than 53° on a toe circle with N_s = c_u/(F γ H) = 0.191, F = "
        f"{TAYLOR:.3f}. The search ({found.outcome}) brackets F at {found.fos:.3f} ± {found.tolerance:g} in "
        f"{len(found.trials)} trials, {found.fos / TAYLOR - 1:+.1%} from Taylor. In the weakest trial that failed "
        f"(F = {found.factor:.3f}) the largest displacement, {moved.max():.3f} m, starts {off_face:.2f} m from the "
        f"face and {height:.2f} m above the toe, and the ground more than 2H behind the crest moves {behind:.2f} of it."
    )
    checks = [
        Check("factor of safety", found.fos, TAYLOR, tolerance, source="Taylor 1937, φ = 0 chart"),
        Check("largest displacement: distance from the face [m]", off_face, 0.0, 1.5 * dx, relative=False,
              source="a toe circle: the slide leaves the face"),
        Check("largest displacement: height above the toe [m]", height, H / 2, H / 2, relative=False,
              source="on the face, between toe and crest"),
        Check("displacement 2H behind the crest / largest", behind, 0.0, 0.1, relative=False,
              source="a toe circle ends behind the crest"),
    ]  # fmt: skip
    return Outcome(summary, checks, found.resolution, png)
