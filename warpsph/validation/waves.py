"""Validation case: the step-loaded elastic column against its closed form, and the convergence of its
error under refinement (docs/method.md, *Verification*)."""

from __future__ import annotations

import math
from warpsph.validation.report import Check, Context, Outcome, case, convergence_plot, figure, shipped_scene

def wave_column(dim: int = 2, **simulation):
    """The shipped wave column; in 1D without its side walls and point probes; simulation keys overridden."""
    scene = shipped_scene("wave_column")
    scene.simulation.dim = dim
    for key, value in simulation.items():
        setattr(scene.simulation, key, value)
    if dim == 1:
        scene.boundaries = [b for b in scene.boundaries if b.axis == "y"]
        scene.probes = [p for p in scene.probes if p.kind != "point"]
    return scene.validate()


def observed_orders(spacings, errors) -> list[float]:
    """Orders log(e_{i−1}/e_i)/log(h_{i−1}/h_i) between successive resolutions."""
    return [math.log(errors[i - 1] / errors[i]) / math.log(spacings[i - 1] / spacings[i])
            for i in range(1, len(errors))]  # fmt: skip


@case("wave_column", "Step wave in an elastic column", minutes=1.5)
def wave_column_case(context: Context) -> Outcome:
    from warpsph.verification import column_stress_run, step_wave_metrics

    scene = wave_column(2)
    sigma0 = -scene.loads[0].traction[1]
    height, t_end = 10.0, 0.05

    def measure(scene):
        c = scene.materials["soil"].p_wave_speed
        run = column_stress_run(scene, t_end, device=context.device)
        m = step_wave_metrics(run.times, run.samples, height=height, speed=c, sigma0=sigma0, dx=scene.simulation.dx)
        return m, c, run

    shown, c, run = measure(scene)
    spacings = [0.2, 0.1] if context.quick else [0.2, 0.1, 0.05, 0.025]
    errors = [measure(wave_column(1, dx=dx))[0].l2_error for dx in spacings]
    orders = observed_orders(spacings, errors)

    fig, (left, right) = figure(1, 2)
    t, (y, syy) = run.times[-1], run.samples[-1]
    front = height - c * t
    left.plot(-syy / sigma0, y, ".", ms=3, label="warpsph, 2D")
    left.plot([0, 0, 1, 1], [0, front, front, height], "k-", lw=1, label="closed form")
    left.set(xlabel="−σ_yy / σ₀", ylabel="height y [m]", title=f"t = {1e3 * t:.1f} ms")
    left.legend(loc="lower right")
    convergence_plot(right, spacings, errors, 0.5, "L2 error of −σ_yy/σ₀ (1D)")
    right.set(ylabel="L2 error")
    name = context.save(fig, "wave_column")
    n = run.model.particle_count
    summary = (
        f"A compressive step σ₀ = {sigma0 / 1e3:g} kPa on the top of the shipped laterally confined column "
        f"(scenes/wave_column.toml, H = {height:g} m) sends a front down at the P-wave speed c = √(E_oed/ρ) = "
        f"{c:.1f} m/s, with −σ_yy = σ₀ behind it. The front speed is the slope of the loaded length "
        f"∫(−σ_yy/σ₀) dy while the front is 30–70 % down, {shown.front_speed:.2f} m/s "
        f"({100 * (shown.front_speed / c - 1):+.2f} %); the plateau behind it is {shown.plateau_mean:.4f} σ₀, "
        f"with the Gibbs overshoot of an unstabilised step at the front ({100 * shown.overshoot:.0f} %). A step is "
        f"a discontinuity, so the L2 error converges at order ½ at best (a front smeared over a fixed number of "
        f"particles) and lower where the step rings; measured orders "
        f"{', '.join(f'{o:.2f}' for o in orders)} between Δx = {', '.join(f'{dx:g}' for dx in spacings)} m."
    )  # fmt: skip
    checks = [
        Check("front speed [m/s]", shown.front_speed, c, 0.01, source="c = √(E_oed/ρ)"),
        Check("plateau −σ_yy/σ₀", shown.plateau_mean, 1.0, 0.03, source="closed form"),
        Check("order of the L2 error", min(orders), 0.5, 0.5, relative=False, source="0 to ½ for a step"),
    ]
    resolution = f"2D: Δx = {scene.simulation.dx:g} m, {n} particles, {run.steps} steps; 1D: Δx as plotted"
    return Outcome(summary, checks, resolution, name)
