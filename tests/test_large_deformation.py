"""Large deformation (``simulation.large_deformation``): ghosts re-planned from the current positions,
virtual points regenerated from the real particles, particles kept inside fixed and slip planes.

- At the start a re-plan must reproduce the builder's layout, and regeneration the start's virtual
  points (positions, densities, materials, origins, velocity-region members): the inside test
  (Shepard sum ≥ INSIDE_SHEPARD) is calibrated on it, concave corners included.
- A block resting under gravity on a slip floor and sliding along it (a rigid translation, an exact
  solution: geostatic stress, no vertical motion) for three of its widths: far beyond the start's
  ghosts, which without re-planning leave it with no floor.
- A run split by --resume is bit-identical across re-plans (the layout is in the checkpoint).
"""

import dataclasses

import numpy as np
import pytest

from warpsph.builder import build
from warpsph.scene import Body, Boundary, Material, Scene, Simulation
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver
from test_resume import whole_and_resumed

WIDTH, HEIGHT, SPEED = 0.5, 0.25, 2.0
DENSITY, E, NU, G = 2000.0, 2.0e6, 0.3, 9.81


def large(scene: Scene, virtual_points: str = "regenerated") -> Scene:
    sim = dataclasses.replace(scene.simulation, large_deformation=True, virtual_points=virtual_points)
    return dataclasses.replace(scene, simulation=sim)


def _ghost_pairs(model, prefix: str) -> set:
    g = getattr(model, f"{prefix}_ghost_count")
    src = getattr(model, f"{prefix}_ghost_source").numpy()[:g]
    chain = getattr(model, f"{prefix}_ghost_planes").numpy()[:g]
    return {(int(s), *map(int, c)) for s, c in zip(src, chain)}


@pytest.mark.parametrize("name", ["footing_prandtl.toml", "cantilever.toml", "block_3d.toml"])
def test_replan_at_the_start_reproduces_the_builders_layout(scenes_dir, name):
    model, state = build(large(load_scene(scenes_dir / name)))
    ghosts = {p: _ghost_pairs(model, p) for p in ("particle", "virtual")}
    n_virtual = model.virtual_count
    before = {k: getattr(a, "numpy")()[:n_virtual].copy()
              for k, a in (("q", state.virtual_q), ("rho", state.virtual_density), ("mass", model.virtual_mass),
                           ("material", model.virtual_material), ("origin", model.virtual_origin))}  # fmt: skip
    regions = set(model.region_virtual.numpy().tolist())
    solver = Solver(model)
    solver.layout.replan(state)
    assert model.virtual_count == n_virtual
    order = np.lexsort(before["q"].T[::-1])
    after_q = state.virtual_q.numpy()[:n_virtual]
    new_order = np.lexsort(after_q.T[::-1])
    np.testing.assert_allclose(after_q[new_order], before["q"][order], atol=1e-12)
    np.testing.assert_allclose(state.virtual_density.numpy()[new_order], before["rho"][order], rtol=1e-12)
    np.testing.assert_allclose(model.virtual_mass.numpy()[new_order], before["mass"][order], rtol=1e-12)
    np.testing.assert_array_equal(model.virtual_material.numpy()[new_order], before["material"][order])
    np.testing.assert_allclose(model.virtual_origin.numpy()[new_order], before["origin"][order], atol=1e-12)
    assert len(model.region_virtual.numpy()) == len(regions)
    assert _ghost_pairs(model, "particle") == ghosts["particle"]
    assert len(_ghost_pairs(model, "virtual")) == len(ghosts["virtual"])


def sliding_block(large_deformation: bool, end_time: float, speed: float = SPEED,
                  virtual_points: str = "advected") -> Scene:  # fmt: skip
    """A block on a slip floor under gravity, geostatic with K0 = 0, sliding at ``speed`` along x."""
    return Scene(
        name="sliding_block",
        simulation=Simulation(dim=2, dx=0.05, end_time=end_time, gravity=(0.0, -G, 0.0),
                              large_deformation=large_deformation, virtual_points=virtual_points),  # fmt: skip
        materials={"soil": Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU,
                                    k0=0.0)},  # σ_xx = 0: the free sides are at rest
        bodies=[Body(name="block", material="soil", min=(0.0, 0.0, 0.0), max=(WIDTH, HEIGHT, 0.0),
                     velocity=(speed, 0.0, 0.0), geostatic=True)],  # fmt: skip
        boundaries=[Boundary(name="floor", kind="slip", axis="y", position=0.0, side="min")],
    ).validate()


def slide(large_deformation: bool, duration: float, speed: float = SPEED, virtual_points: str = "advected"):
    """Run the sliding block for ``duration`` [s]; measures of its departure from rigid sliding."""
    scene = sliding_block(large_deformation, duration, speed, virtual_points)
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    steps = int(round(scene.simulation.end_time / dt))
    for k in range(steps):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
    n = model.particle_count
    x0 = model.particle_x0
    q, v = state.particle_q.numpy()[:n], state.particle_v.numpy()[:n]
    sigma_yy = state.particle_stress.numpy()[:n, 1, 1]
    interior = (x0[:, 0] > 0.1) & (x0[:, 0] < WIDTH - 0.1) & (x0[:, 1] < HEIGHT - 0.1)
    geostatic = -DENSITY * G * (HEIGHT - x0[:, 1])
    return {
        "drop": float(np.max(x0[:, 1] - q[:, 1])),
        "vertical_speed": float(np.max(np.abs(v[:, 1]))),
        "slid": float(np.mean(q[:, 0] - x0[:, 0])),
        "horizontal_speed_error": float(np.max(np.abs(v[:, 0] - speed))),
        "stress_error": float(np.max(np.abs(sigma_yy - geostatic)[interior]) / (DENSITY * G * HEIGHT)),
        "replans": solver.layout.replans if solver.layout else 0,
    }


def test_block_slides_three_widths_on_its_floor():
    """Galilean invariance: sliding three widths with re-planned ghosts and advected virtual points
    repeats the block at rest to round-off (the block on its own, with free sides, is not quite at
    rest in the scheme: that is the reference, not zero). Both run with large deformation, which also
    leaves the surface term undivided by the particles' shares (docs/method.md)."""
    duration = 3 * WIDTH / SPEED
    at_rest = slide(True, duration, speed=0.0)
    moved = slide(True, duration)
    print("\nat rest:", at_rest, "\nsliding, large deformation:", moved)
    assert moved["replans"] > 10 and abs(moved["slid"] - 3 * WIDTH) < 0.01 * WIDTH
    assert moved["drop"] == pytest.approx(at_rest["drop"], rel=1e-6, abs=1e-12)
    assert moved["vertical_speed"] == pytest.approx(at_rest["vertical_speed"], rel=1e-6)
    assert moved["stress_error"] == pytest.approx(at_rest["stress_error"], rel=1e-6)
    assert moved["horizontal_speed_error"] == pytest.approx(at_rest["horizontal_speed_error"], rel=1e-4, abs=1e-9)


def test_block_dropped_onto_a_floor_lands_on_it():
    """A block released 2Δx above a fixed floor, beyond the start's ghost band (2.5h): with re-planned
    ghosts (and its bottom row joining the floor, ghost_layout.CONTACT) it lands and settles; with
    the start's layout it has no floor and falls through."""
    gap, dx = 0.1, 0.05

    def drop(large_deformation: bool):
        scene = Scene(
            name="dropped_block",
            simulation=Simulation(dim=2, dx=dx, end_time=0.6, gravity=(0.0, -G, 0.0),
                                  large_deformation=large_deformation, artificial_viscosity=0.2),  # fmt: skip
            materials={"soil": Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU)},
            bodies=[Body(name="block", material="soil", min=(0.0, gap, 0.0), max=(WIDTH, gap + HEIGHT, 0.0))],
            boundaries=[Boundary(name="floor", kind="fixed", axis="y", position=0.0, side="min")],
        ).validate()
        model, state = build(scene)
        scratch = model.state()
        scratch.assign(state)
        solver, dt = Solver(model), scene.time_step
        lowest = np.inf
        for k in range(int(round(scene.simulation.end_time / dt))):
            solver.step(state, scratch, k * dt, dt)
            state, scratch = scratch, state
            lowest = min(lowest, float(state.particle_q.numpy()[: model.particle_count, 1].min()))
        v = state.particle_v.numpy()[: model.particle_count]
        return lowest, float(np.mean(v[:, 1]))

    lowest, mean_vy = drop(True)
    print(f"\nre-planned: lowest point {lowest:.4f} m, mean v_y at 0.6 s {mean_vy:.4f} m/s")
    assert lowest >= 0.0 and abs(mean_vy) < 0.1 * np.sqrt(2 * G * gap)
    lowest, mean_vy = drop(False)
    print(f"start's layout: lowest point {lowest:.4f} m, mean v_y {mean_vy:.4f} m/s")
    assert lowest < -HEIGHT


def test_regenerated_virtual_points_keep_the_sliding_block_on_its_floor():
    """Regenerating the virtual points on the start's lattice loses the staggering of the two sets
    whenever the reals have moved by a fraction of a cell: not Galilean invariant. Measured: vertical
    speed 0.158 m/s against 0.065 advected, σ_yy error 0.43 against 0.20 of ρgH."""
    duration = 3 * WIDTH / SPEED
    moved = slide(True, duration, virtual_points="regenerated")
    print("\nsliding, regenerated:", moved)
    assert moved["drop"] < 0.05 * 0.05
    assert moved["vertical_speed"] < 0.1 * SPEED
    assert moved["stress_error"] < 0.5


def test_resume_across_replans_is_bit_identical(tmp_path):
    scene = sliding_block(True, 1.0)
    scene.output.frame_interval = 20 * scene.time_step
    whole, first, _ = whole_and_resumed(scene, tmp_path, 40, 81)
    assert whole.solver.layout.replans > first.solver.layout.replans > 0


def test_basal_friction_slows_a_sliding_block():
    """Coulomb basal friction (a slip floor's friction_angle φ_b = 10°) on a block sliding at v0 = 1 m/s.
    Rigid, it would decelerate at a = μ F_n / M (μ = tan φ_b, F_n = Σ (−σ_yy) Δx the normal force its
    floor row carries, 5/6 of the weight M g here: six rows of particles carry the mass of 6 Δx, the
    geostatic stress the weight of the 5 Δx between the top and bottom rows' centres) and stop at
    v0/a = 0.69 s. Measured: the friction takes the block's momentum at 0.86 a over the first 0.25 s,
    but it acts on the floor row alone, and the slip plane's even tangential velocity couples that row
    weakly to the rows above: the row slows faster than the block (0.47 against 0.69 m/s at 0.25 s,
    0.03 against 0.26 at 0.86 s), which slides on over it at a = 0.3–0.7 of the rigid value (a known
    limit, docs/method.md)."""
    mu, v0, end = np.tan(np.radians(10.0)), 1.0, 0.9
    scene = sliding_block(True, end, speed=v0)
    scene.boundaries[0].friction_angle = 10.0
    model, state = build(scene.validate())
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    n, mass = model.particle_count, model.particle_mass.numpy()[: model.particle_count]
    floor = model.particle_x0[:, 1] == 0.0
    normal = float(np.sum(-state.particle_stress.numpy()[:n, 1, 1][floor]) * model.dx)
    decel = mu * normal / float(np.sum(mass))
    mean_v, t_check = [], (0.25, end)
    for k in range(int(round(end / dt))):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if len(mean_v) < 2 and (k + 1) * dt >= t_check[len(mean_v)] - 0.5 * dt:
            mean_v.append(float(np.sum(mass * state.particle_v.numpy()[:n, 0]) / np.sum(mass)))
    print(f"\nF_n / (M g) = {normal / (float(np.sum(mass)) * G):.4f}; mean v_x {mean_v[0]:.4f} m/s at 0.25 s "
          f"(rigid {v0 - decel * 0.25:.4f}), {mean_v[1]:.4f} m/s at {end} s (rigid 0)")
    assert normal / (float(np.sum(mass)) * G) == pytest.approx(5 / 6, rel=0.02)
    assert 0.8 * decel * 0.25 < v0 - mean_v[0] <= decel * 0.25  # never more than Coulomb allows
    assert 0.0 < mean_v[1] < mean_v[0]
