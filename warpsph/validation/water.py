"""Validation cases of the pore water: Terzaghi's consolidation against its closed form, with the order
of convergence, and the undrained limit (docs/method.md, *Verification*)."""

from __future__ import annotations

import numpy as np

from warpsph.validation.report import Check, Context, Outcome, case, convergence_plot, figure, shipped_scene
from warpsph.validation.waves import observed_orders

TV_SHOWN = (0.1, 0.3, 0.5)
"""Time factors of the isochrones and of the L2 checks."""


def _pressure_and_top(model, state):
    """(pore pressures of the owned particles, the top particle's vertical displacement [m])."""
    n = model.particle_count
    p = state.particle_pore_pressure.numpy()[:n].astype(np.float64)
    q = state.particle_q.numpy()[:n].astype(np.float64)
    top = int(np.argmax(model.particle_x0[:, 1]))
    return p, float(q[top, 1] - model.particle_x0[top, 1])


def terzaghi_run(dx: float, tv: list[float], device: str):
    """The shipped Terzaghi column at spacing ``dx`` sampled at the time factors ``tv``: (run, constants,
    height)."""
    from warpsph.verification import consolidation_constants, run_sampled

    scene = shipped_scene("terzaghi")
    scene.simulation.dx = dx
    scene = scene.validate()
    height, sigma0 = 10.0, -scene.loads[0].traction[1]
    constants = consolidation_constants(scene.materials["soil"], height, sigma0)
    steps = [max(1, round(t * height**2 / constants.cv / scene.time_step)) for t in tv]
    return run_sampled(scene, steps, _pressure_and_top, device=device), constants, height


@case("terzaghi", "Terzaghi consolidation", minutes=2.0)
def terzaghi_case(context: Context) -> Outcome:
    from warpsph.verification import degree_of_consolidation, pressure_l2, terzaghi_pressure

    spacings = [2.0, 1.0] if context.quick else [1.0, 0.5, 0.25, 0.125]
    curve = sorted(set(np.round(np.arange(0.02, 0.501, 0.02), 3)) | set(TV_SHOWN))
    errors, last = [], None
    for dx in spacings:
        run, (p0, cv, s0, s_inf), height = terzaghi_run(dx, curve, context.device)
        zeta = height - run.model.particle_x0[:, 1]
        tvs = [cv * t / height**2 for t in run.times]
        l2 = {round(tv, 3): pressure_l2(p, zeta, height, p0, tv) for tv, (p, _) in zip(tvs, run.samples)}
        errors.append(max(l2[t] for t in TV_SHOWN))
        last = run, zeta, tvs, l2
    run, zeta, tvs, l2 = last
    u_pressure = [1.0 - np.mean(p) / p0 for p, _ in run.samples]
    u_settlement = [(-top) / (s_inf - s0) for _, top in run.samples]
    orders = observed_orders(spacings, errors)

    fig, (left, middle, right) = figure(1, 3, width=13.0)
    fine = np.linspace(0.0, height, 201)
    for k, tv in enumerate(TV_SHOWN):
        i = int(np.argmin(np.abs(np.array(tvs) - tv)))
        order = np.argsort(zeta)
        left.plot(run.samples[i][0][order] / p0, zeta[order], "o", ms=3, color=f"C{k}", label=f"T_v = {tv:g}")
        left.plot(terzaghi_pressure(fine, height, p0, tvs[i]) / p0, fine, "-", color=f"C{k}", lw=1)
    left.invert_yaxis()
    left.set(xlabel="p / p₀", ylabel="depth below the drained top ζ [m]", title="isochrones (lines: closed form)")
    left.legend(loc="upper right")
    dense = np.linspace(0.0, 0.5, 101)
    middle.plot(dense, [degree_of_consolidation(t) if t > 0 else 0.0 for t in dense], "k-", lw=1,
                label="closed form")  # fmt: skip
    middle.plot(tvs, u_pressure, "o", ms=3, label="from the pore pressure")
    middle.plot(tvs, u_settlement, "x", ms=4, label="from the settlement")
    middle.set(xlabel="T_v = c_v t / H²", ylabel="degree of consolidation U", title="U(T_v)")
    middle.legend(loc="lower right")
    convergence_plot(right, spacings, errors, 2.0, "largest L2 / p₀ at the T_v shown")
    right.set(ylabel="L2 / p₀")
    name = context.save(fig, "terzaghi")

    dx = spacings[-1]
    shown = [i for i, tv in enumerate(tvs) if round(tv, 3) in TV_SHOWN]
    u_pressure_error, u_settlement_error = (max(abs(u[i] - degree_of_consolidation(tvs[i])) for i in shown)
                                            for u in (u_pressure, u_settlement))  # fmt: skip
    summary = (
        f"The shipped column (scenes/terzaghi.toml: H = {height:g} m, drained top, impermeable base, σ₀ = 5 kPa, "
        f"c_v = {cv:.3f} m²/s) starts from the undrained state p = p₀ = {p0:.0f} Pa and consolidates. Its pore "
        f"pressure follows p(ζ, t) = Σ (2p₀/M) sin(Mζ/H) exp(−M²T_v) with L2 errors "
        f"{', '.join(f'{l2[t]:.1e}' for t in TV_SHOWN)} of p₀ at T_v = {', '.join(f'{t:g}' for t in TV_SHOWN)} "
        f"(Δx = {dx:g} m); at those times the degree of consolidation is within {u_pressure_error:.4f} of U(T_v) = "
        f"1 − Σ (2/M²) exp(−M²T_v) from the pressure and within {u_settlement_error:.4f} from the settlement, "
        f"which lags at first order in Δx (the top's displacement behind the strain its stresses carry). The "
        f"largest L2 error converges at orders "
        f"{', '.join(f'{o:.2f}' for o in orders)} between Δx = {', '.join(f'{s:g}' for s in spacings)} m."
    )  # fmt: skip
    checks = [Check(f"L2 / p₀ at T_v = {t:g}", l2[t], 0.0, 0.01, relative=False, source="Terzaghi")
              for t in TV_SHOWN]  # fmt: skip
    checks += [Check("largest |U − U(T_v)|, from p", u_pressure_error, 0.0, 0.02, relative=False, source="Terzaghi"),
               Check("largest |U − U(T_v)|, from the settlement", u_settlement_error, 0.0, 0.02, relative=False,
                     source="Terzaghi"),
               Check("order of the L2 error", min(orders), 2.0, 0.5, relative=False, source="a smooth solution")]
    resolution = (f"1D, Δx = {dx:g} m ({run.model.particle_count} particles, {run.steps} steps to T_v = 0.5) "
                  f"shown; Δx = {', '.join(f'{s:g}' for s in spacings)} m in the convergence")  # fmt: skip
    return Outcome(summary, checks, resolution, name)


@case("undrained_limit", "The undrained limit", minutes=0.3)
def undrained_case(context: Context) -> Outcome:
    from warpsph.verification import run_sampled

    steps = 100
    scene = shipped_scene("terzaghi")
    scene.simulation.dx = 0.2 if context.quick else 0.1
    soil, body = scene.materials["soil"], scene.bodies[0]
    soil.hydraulic_conductivity, soil.water_bulk_modulus = 1e-12, 1e12
    body.pore_pressure, body.stress = 0.0, (0.0,) * 6
    scene = scene.validate()
    sigma0, height, dx = -scene.loads[0].traction[1], 10.0, scene.simulation.dx
    run = run_sampled(scene, [steps], _pressure_and_top, device=context.device)
    y = run.model.particle_x0[:, 1]
    p = run.samples[0][0]
    order = np.argsort(y)
    interior = y[order] < height - 3 * dx
    ratio = p[order] / sigma0
    jump = float(np.max(np.abs(np.diff(ratio[interior]))))
    worst = float(np.max(np.abs(ratio[interior] - 1.0)))

    fig, axes = figure(width=5.0, height=4.0)
    axes.plot(ratio, y[order], "o", ms=3, label="warpsph")
    axes.axvline(1.0, color="k", lw=1, label="undrained: p = σ₀")
    axes.set(xlabel="p / σ₀", ylabel="height y [m]", xlim=(0.0, 1.1), title=f"after {steps} steps")
    axes.legend(loc="lower left")
    name = context.save(fig, "undrained_limit")
    summary = (
        f"The Terzaghi column started unloaded with k_h = 1e-12 m/s and K_w = 1e12 Pa, under the step σ₀ = "
        f"{sigma0 / 1e3:g} kPa on its drained top: incompressible water that cannot move carries the whole load, "
        f"p = σ₀. After {steps} steps at the drained wave's time step (Δt = {scene.time_step:.3g} s: the step does "
        f"not depend on k or K_w) p/σ₀ is within {worst:.1e} of 1 more than 3Δx below the drained face, and "
        f"neighbours differ by at most {jump:.1e} σ₀: no checkerboard."
    )  # fmt: skip
    checks = [Check("largest |p/σ₀ − 1| below 3Δx", worst, 0.0, 0.01, relative=False, source="undrained limit"),
              Check("largest neighbour jump / σ₀", jump, 0.0, 0.01, relative=False, source="no checkerboard")]
    resolution = f"1D, Δx = {dx:g} m, {run.model.particle_count} particles, {steps} steps"
    return Outcome(summary, checks, resolution, name)

