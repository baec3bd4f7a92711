"""Consolidation phases (docs/scenes.md, *Consolidation*): the coupled quasi-static transient in
implicit steps by the fixed-stress split, against Terzaghi's closed form (shared/docs/verification.md,
parameter set A: H = 10 m, σ₀ = 5 kPa, c_v = 3.089 m²/s), from the undrained state at t = 0.

The time error is backward Euler's, set by the step's largest pressure change (2 % of p₀); the
settlement's error is first order in Δx: the column's displacement lags the strain its stresses
carry by about Δx/(2H) (5.3, 2.6 and 1.3 % at Δx = 1, 0.5 and 0.25 m).
"""

import numpy as np
import pytest

from warpsph.errors import SceneError
from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene import Drainage, Effects, Material, Phase
from warpsph.verification import consolidation_constants, degree_of_consolidation, pressure_l2

from test_terzaghi import SIGMA0, consolidating_column

HEIGHT = 10.0
SOIL = Material("soil", density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3, grain_density=2000.0,
                water_bulk_modulus=100e6, hydraulic_conductivity=1e-3)  # fmt: skip
P0, CV, S0, S_INF = consolidation_constants(SOIL, HEIGHT, SIGMA0)


def consolidation_scene(dx: float, tv_end: float = 0.5, frames: int = 5, soil=SOIL, height=HEIGHT,
                        sigma0=SIGMA0, **phase):  # fmt: skip
    scene = consolidating_column(soil, height, dx, sigma0)
    cv = consolidation_constants(soil, height, sigma0)[1]
    scene.phases = [Phase(name="consolidation", kind="consolidation", duration=tv_end * height**2 / cv,
                          frames=frames, **phase)]  # fmt: skip
    scene.output.usd = False
    scene.output.fields = ["displacement", "pore_pressure", "stress"]
    return scene.validate()


def errors(out, dx: float, soil=SOIL, height=HEIGHT, sigma0=SIGMA0) -> list[tuple[float, float, float, float]]:
    """(T_v, L2 of p over p₀, U from the pressure − U, settlement over the closed form's − 1) of
    each frame after the first."""
    p0, cv, s0, s_inf = consolidation_constants(soil, height, sigma0)
    results = load_results(out / "results.h5")
    x0 = results.frame(0)["position"]
    top = np.argmax(x0[:, 1])
    rows = []
    for i in range(1, len(results)):
        frame, tv = results.frame(i), results.times[i] * cv / height**2
        p = frame["pore_pressure"]
        u = degree_of_consolidation(tv)
        settlement = s0 - frame["displacement"][top, 1]
        rows.append((tv, pressure_l2(p, height - x0[:, 1], height, p0, tv), 1.0 - np.mean(p) / p0 - u,
                     settlement / (s0 + (s_inf - s0) * u) - 1.0))  # fmt: skip
    print("\n  T_v   L2/p0    U_p − U   settlement error")
    for tv, l2, du, ds in rows:
        print(f"  {tv:.3f}  {l2:.2e}  {du:+.4f}   {ds:+.4f}")
    return rows


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    out = tmp_path_factory.mktemp("consolidation")
    summary = Run(consolidation_scene(1.0), out).run()
    return out, summary


def test_terzaghi_by_consolidation_phase(coarse):
    """Δx = 1 m to T_v = 0.5: p within 1 % of p₀ (L2) and U within 0.02 at T_v = 0.1 ... 0.5; the
    settlement within Δx/H; one phase, finished, in implicit steps of two or three fixed-stress
    iterations (exact in 1D: the second confirms the first, up to the equilibrium's tolerance)."""
    out, summary = coarse
    for tv, l2, du, ds in errors(out, 1.0):
        assert l2 < 0.01 and abs(du) < 0.02
        assert -1.0 / HEIGHT < ds < 0.0
    assert summary.phases[0]["outcome"] == "finished"
    _, iterations = load_results(out / "results.h5").series("consolidation_iterations")
    print(f"{len(iterations)} steps, fixed-stress iterations: mean {np.mean(iterations):.2f}, max {max(iterations)}")
    assert 10 < len(iterations) < 150 and np.mean(iterations) < 3.0 and max(iterations) <= 8


def test_late_steps_are_sized_on_what_remains_to_dissipate(tmp_path):
    """Δx = 1 m to T_v = 0.8: the steps' accuracy follows the excess that remains, so the pressure's error
    does not grow as it decays (measured: L2 2.1e-3, 3.2e-3, 3.3e-3, 2.9e-3 p₀ at T_v = 0.2, 0.4, 0.6, 0.8
    and 2.3e-3 at 1.0, U within 0.01; sized on the phase's largest excess the L2 grew to 4.1e-3, 5.1e-3 and
    5.5e-3 at T_v = 0.4, 0.6 and 0.8)."""
    Run(consolidation_scene(1.0, tv_end=0.8, frames=4), tmp_path).run()
    rows = errors(tmp_path, 1.0)
    l2 = [r[1] for r in rows]
    assert max(l2) < 0.004 and l2[-1] <= l2[-2]
    assert all(abs(du) < 0.01 for _, _, du, _ in rows)


SOFT_CLAY = Material("clay", density=1990.0, youngs_modulus=5e6, poisson_ratio=0.3, porosity=0.4, grain_density=2650.0,
                     water_bulk_modulus=2.2e9, hydraulic_conductivity=1e-7)  # fmt: skip
"""Soft clay with real water (B ≈ 1), c_v = 4.1e-4 m²/s: a 6 m layer consolidates over a day."""


@pytest.mark.parametrize("start", ["undrained", "load switched on"])
def test_soft_clay_with_real_water_from_either_start(tmp_path, start):
    """A 6 m soft clay layer under 50 kPa (issue 48), Δx = 0.5 m, to T_v = 0.4, from its undrained state
    or unloaded with the load switched on at the phase's start: p within 1 % of p₀ (L2), U within 0.01,
    the phase finished. From the undrained state the first step's skeleton takes the drained top's
    pressure at once: held at the undrained p₀ there, the top particle's stress (the load alone) and
    pore pressure summed to twice the load, and the step's equilibrium never converged. Measured to
    T_v = 1: L2 9.9e-4 … 2.9e-4 p₀ and U − U(T_v) +0.0086 … +0.0010 at T_v = 0.2 … 1 (Δx = 0.5 m, the same
    at k = 1e-5 m/s and with the load switched on), 7.3e-4 … 1.7e-4 and +0.0041 … +0.0008 at Δx = 0.25 m."""
    scene = consolidation_scene(0.5, tv_end=0.4, frames=2, soil=SOFT_CLAY, height=6.0, sigma0=50e3)
    if start == "load switched on":
        scene.bodies[0].pore_pressure, scene.bodies[0].stress = 0.0, (0.0,) * 6
    summary = Run(scene, tmp_path).run()
    assert summary.phases[0]["outcome"] == "finished"
    for _tv, l2, du, _ds in errors(tmp_path, 0.5, soil=SOFT_CLAY, height=6.0, sigma0=50e3):
        assert l2 < 0.01 and abs(du) < 0.01


@pytest.mark.slow
def test_terzaghi_settlement_converges_at_first_order(coarse, tmp_path):
    """Δx = 0.5 m against 1 m: the pressure within 0.5 % of p₀, the settlement's lag halved."""
    Run(consolidation_scene(0.5), tmp_path).run()
    fine = errors(tmp_path, 0.5)
    for (_, _, _, ds_coarse), (_, l2, _, ds_fine) in zip(errors(coarse[0], 1.0), fine):
        assert l2 < 0.005
        assert ds_fine / ds_coarse == pytest.approx(0.5, abs=0.1)


def test_consolidation_resumes_bit_identical(tmp_path):
    scene = consolidation_scene(1.0, tv_end=0.01, frames=2)
    duration = scene.phases[0].duration
    Run(scene, tmp_path / "whole").run()
    Run(scene, tmp_path / "split", end_time=0.5 * duration).run()
    Run(scene, tmp_path / "split", end_time=None, resume=True).run()
    whole, split = load_results(tmp_path / "whole" / "results.h5"), load_results(tmp_path / "split" / "results.h5")
    assert whole.times[-1] == split.times[-1] == pytest.approx(duration)
    for key in ("pore_pressure", "position", "stress"):
        np.testing.assert_array_equal(whole.frame(len(whole) - 1)[key], split.frame(len(split) - 1)[key])


def test_consolidation_phase_input_errors():
    scene = consolidation_scene(1.0)
    scene.effects = Effects(pore_water=False)
    scene.bodies[0].pore_pressure = 0.0
    scene.loads[0].drainage = Drainage()
    with pytest.raises(SceneError, match=r"phases.consolidation.kind.*pore_water"):
        scene.validate()
    scene = consolidation_scene(1.0)
    scene.phases[0].steady = True
    with pytest.raises(SceneError, match=r"phases.consolidation.steady.*transient"):
        scene.validate()
    scene = consolidation_scene(1.0)
    scene.phases[0].duration = 0.0
    with pytest.raises(SceneError, match=r"phases.consolidation.duration"):
        scene.validate()
    scene = consolidation_scene(1.0)  # the water has nowhere to go: nothing would consolidate
    scene.loads[0].drainage = Drainage()
    scene.pressure.free_surface = "impermeable"
    with pytest.raises(SceneError, match=r"^phases.consolidation.kind: .*nowhere for it to go"):
        scene.validate()


def test_an_iteration_that_never_converges_stops_after_ten_halvings(tmp_path, monkeypatch):
    """A fixed-stress iteration that fails whatever the step (a stall at the skeleton equilibrium's
    precision) stops the phase after ten tries in a row, the step halved after each, not after the forty
    that take it down to 1e-12 of the phase: one line naming the stall, the checkpoint before it kept."""
    from warpsph.errors import SimulationError
    from warpsph.phases.flow import MAX_FAILED_TRIES
    from warpsph.stages.consolidation import FixedStressSplit

    tries = []

    def never(self, t, dt):
        tries.append(dt)
        self.collapsed, self.iterations = False, 30
        return False

    monkeypatch.setattr(FixedStressSplit, "solve", never)
    with pytest.raises(SimulationError, match="fixed-stress iteration does not converge: 10 tries in a row"):
        Run(consolidation_scene(1.0), tmp_path).run()
    assert len(tries) == MAX_FAILED_TRIES
    assert tries[-1] == pytest.approx(tries[0] / 2 ** (MAX_FAILED_TRIES - 1))
    assert (tmp_path / "checkpoint.h5").exists()
