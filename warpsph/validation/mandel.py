"""Mandel's problem (``scenes/mandel.toml``) against the closed form of Cheng & Detournay (1988): the shipped
consolidation phase and a dynamic saturated run from the undrained state (docs/method.md, *Rigid plates*)."""

from __future__ import annotations

import numpy as np

from warpsph.validation.report import Check, Context, Outcome, case, figure, run_scene, shipped_scene

HALF_WIDTH, HEIGHT, FORCE = 1.0, 0.5, 50e3
"""The shipped quarter specimen: a [m], b [m] and the plate's force F on the half-width [N/m]."""
TIMES_SHOWN = (0.05, 0.2, 0.5)
"""Time factors T = c t / a² of the profiles and of the L2 checks."""


def mandel_scene(t_end: float, frames: int, dynamic: bool = False):
    """(the shipped scene to the time factor ``t_end`` with ``frames`` frames, its
    :class:`~warpsph.verification.Mandel` constants); ``dynamic``: a dynamic run from the closed form's
    undrained state (p(x, 0⁺) and its effective stress) in place of the consolidation phase."""
    from warpsph.verification import mandel_constants, mandel_undrained_pressure

    scene = shipped_scene("mandel")
    m = mandel_constants(scene.materials["soil"])
    duration = t_end * HALF_WIDTH**2 / m.c
    scene.output.usd = False
    if dynamic:
        p0 = mandel_undrained_pressure(HALF_WIDTH, FORCE, m)
        sigma = FORCE / HALF_WIDTH
        body = scene.bodies[0]
        body.pore_pressure = p0
        body.stress = (p0, p0 - sigma, p0 - m.nu_u * sigma, 0.0, 0.0, 0.0)  # effective, plane strain
        scene.phases = []
        scene.simulation.end_time = duration
        scene.output.frame_interval = duration / frames
        scene.output.probe_every = 10
    else:
        scene.phases[0].duration, scene.phases[0].frames = duration, frames
    return scene.validate(), m


def measured(results, m, undrained_start: bool) -> list[tuple[float, float, float, float]]:
    """(T, L2 of p over p(0, 0⁺), settlement [m], the closed form's) at each frame after the first of a run's
    ``results``. A run from the undrained state adds the closed form's undrained settlement to its plate's
    displacement: its start carries that state's stresses, not its displacement."""
    from warpsph.verification import mandel_pressure, mandel_settlement, mandel_undrained_pressure

    x0 = results.frame(0)["position"]
    p0 = mandel_undrained_pressure(HALF_WIDTH, FORCE, m)
    times, plate = results.series("plate_displacement_y")
    start = mandel_settlement(HEIGHT, HALF_WIDTH, FORCE, 0.0, m) if undrained_start else 0.0
    rows = []
    for i in range(1, len(results)):
        t = results.times[i]
        exact = mandel_pressure(x0[:, 0], HALF_WIDTH, FORCE, t, m)
        l2 = float(np.sqrt(np.mean((results.frame(i)["pore_pressure"] - exact) ** 2)) / p0)
        settlement = start - float(plate[np.argmin(np.abs(times - t))])
        rows.append((t * m.c / HALF_WIDTH**2, l2, settlement, mandel_settlement(HEIGHT, HALF_WIDTH, FORCE, t, m)))
    return rows


def centre_rise(results, m) -> tuple[float, float]:
    """(the centre's largest pore pressure as sampled in a run's ``results``, the closed form's peak), over
    p(0, 0⁺)."""
    from warpsph.verification import mandel_pressure, mandel_undrained_pressure

    _, centre = results.series("centre_pressure")
    p0 = mandel_undrained_pressure(HALF_WIDTH, FORCE, m)
    dense = np.linspace(0.01, 0.3, 59) * HALF_WIDTH**2 / m.c
    peak = max(mandel_pressure([0.0], HALF_WIDTH, FORCE, t, m)[0] for t in dense)
    return float(np.max(centre) / p0), float(peak / p0)


def _at(rows, tv: float):
    return min(rows, key=lambda row: abs(row[0] - tv))


@case("mandel", "Mandel's problem", minutes=2.0)
def mandel_case(context: Context) -> Outcome:
    from warpsph.verification import mandel_pressure, mandel_settlement, mandel_undrained_pressure

    t_end = 0.5 if context.quick else 1.0
    runs, rows, rises = {}, {}, {}
    for label, dynamic in (("consolidation", False), ("dynamic", True)):
        scene, m = mandel_scene(t_end, 20, dynamic)
        results, _ = run_scene(context, "mandel", label, scene)
        runs[label] = results
        rows[label] = measured(results, m, undrained_start=dynamic)
        rises[label] = centre_rise(results, m)
    p0 = mandel_undrained_pressure(HALF_WIDTH, FORCE, m)

    fig, (left, middle, right) = figure(1, 3, width=13.0)
    fine = np.linspace(0.0, HALF_WIDTH, 101)
    phase = runs["consolidation"]
    x0 = phase.frame(0)["position"][:, 0]
    for k, tv in enumerate(TIMES_SHOWN):
        i = 1 + rows["consolidation"].index(_at(rows["consolidation"], tv))
        left.plot(x0, phase.frame(i)["pore_pressure"] / p0, "o", ms=3, color=f"C{k}", label=f"T = {tv:g}")
        left.plot(fine, mandel_pressure(fine, HALF_WIDTH, FORCE, tv / m.c, m) / p0, "-", color=f"C{k}", lw=1)
    left.set(xlabel="x / a", ylabel="p / p(0, 0⁺)", title="pressure across the specimen (lines: closed form)")
    left.legend(loc="lower left")
    dense = np.linspace(0.0, t_end, 201)
    middle.plot(dense, [mandel_pressure([0.0], HALF_WIDTH, FORCE, t / m.c, m)[0] / p0 for t in dense], "k-", lw=1,
                label="closed form")  # fmt: skip
    for label, marker in (("consolidation", "o"), ("dynamic", "-")):
        t, centre = runs[label].series("centre_pressure")
        middle.plot(t * m.c, centre / p0, marker, ms=3, lw=0.8, label=f"{label}")
    middle.set(xlabel="T = c t / a²", ylabel="p(0, t) / p(0, 0⁺)", title="the centre (Mandel–Cryer rise)")
    middle.legend(loc="upper right")
    right.plot(dense, [mandel_settlement(HEIGHT, HALF_WIDTH, FORCE, t / m.c, m) * 1e6 for t in dense], "k-", lw=1,
               label="closed form")  # fmt: skip
    for label, marker in (("consolidation", "o"), ("dynamic", "x")):
        right.plot([r[0] for r in rows[label]], [r[2] * 1e6 for r in rows[label]], marker, ms=3, label=label)
    right.set(xlabel="T = c t / a²", ylabel="plate settlement [µm]", title="the plate")
    right.legend(loc="lower right")
    name = context.save(fig, "mandel")

    shown = [tv for tv in TIMES_SHOWN if tv <= t_end]
    checks = []
    for label in ("consolidation", "dynamic"):
        checks += [Check(f"{label}: L2 / p(0, 0⁺) at T = {tv:g}", _at(rows[label], tv)[1], 0.0, 0.02, relative=False,
                         source="Cheng & Detournay (1988)") for tv in shown]  # fmt: skip
        checks.append(Check(f"{label}: the centre's largest pressure / p(0, 0⁺)", rises[label][0], rises[label][1],
                            0.025 if label == "consolidation" else 0.02, source="its peak"))  # fmt: skip
        checks += [Check(f"{label}: settlement at T = {tv:g} [µm]", _at(rows[label], tv)[2] * 1e6,
                         _at(rows[label], tv)[3] * 1e6, 0.02, source="Abousleiman et al. (1996)")
                   for tv in shown if tv >= 0.2 or label == "consolidation"]  # fmt: skip
    summary = (
        f"The shipped quarter specimen (scenes/mandel.toml: a = {HALF_WIDTH:g} m, b = {HEIGHT:g} m, Δx = "
        f"{scene.simulation.dx:g} m; E = 30 MPa, ν = {m.nu:g}, ν_u = {m.nu_u:.3f}, B = {m.skempton:.3f}, c = "
        f"{m.c:.3f} m²/s) under a smooth impermeable rigid plate carrying F = {FORCE / 1e3:g} kN/m on the half-width, "
        f"its side drained and free. The consolidation phase switches the force on at its start and computes the "
        f"undrained response in its first implicit step; the dynamic run starts from the closed form's undrained "
        f"state p(x, 0⁺) = F B (1 + ν_u)/(3a) = {p0 / 1e3:.2f} kPa. Both follow p(x, t) with L2 errors of at most "
        f"{max(_at(rows['consolidation'], tv)[1] for tv in shown):.4f} and "
        f"{max(_at(rows['dynamic'], tv)[1] for tv in shown):.4f} of p(0, 0⁺) at T = "
        f"{', '.join(f'{tv:g}' for tv in shown)}. The centre's pressure rises above its undrained value to "
        f"{rises['consolidation'][0]:.3f} (sampled at the phase's frames) and {rises['dynamic'][0]:.3f} (the dynamic "
        f"run, which rings about it) of p(0, 0⁺), the closed form's peak {rises['consolidation'][1]:.3f}. The "
        f"plate settles as the closed form; in the dynamic run the drained side's first row consolidates at once, "
        f"a lag first order in Δx that has faded by T = 0.2."
    )  # fmt: skip
    resolution = (f"2D, Δx = {scene.simulation.dx:g} m ({runs['consolidation'].frame(0)['position'].shape[0]} "
                  f"particles), to T = {t_end:g}")  # fmt: skip
    return Outcome(summary, checks, resolution, name)
