"""Free surfaces detected from the particles (no boundary plane) stay stable and traction-free.

- A free elastic block with small random velocities: no energy is created (the surface band's
  weak traction-free form, taylor.py), kinetic energy after 3000 steps ≤ its start.
- A block on a fixed base under suddenly applied gravity: the top's mean downward speed stays within
  the 1D bound g H / c (the column rings between 0 and twice the static settlement; a free side lets
  the top spread, which lowers it), and no particle exceeds twice that.
- A geostatic layer under a free top (slip sides) stays at rest.
- The shipped cantilever over its end time: bounded tip motion and speeds.
"""

import numpy as np

from warpsph.builder import build
from warpsph.scene import Body, Boundary, Material, Scene, Simulation
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver

SOIL = {"soil": Material("soil", density=1000.0, youngs_modulus=1.0e8, poisson_ratio=0.25)}


def advance(scene, steps, state_hook=None, every=100, observe=None):
    """Run ``steps`` steps; every ``every`` steps record the largest speed [m/s] and call ``observe(model, state)``."""
    model, state = build(scene)
    if state_hook:
        state_hook(model, state)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    speeds = []
    for k in range(steps):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if k % every == 0:
            speeds.append(np.linalg.norm(state.particle_v.numpy()[: model.particle_count], axis=1).max())
            if observe:
                observe(model, state)
    return model, state, np.array(speeds)


def test_free_block_creates_no_energy():
    scene = Scene(simulation=Simulation(dim=2, dx=0.1), materials=SOIL,
                  bodies=[Body("block", "soil", min=(0, 0, 0), max=(2, 1, 0))]).validate()  # fmt: skip

    def kick(model, state):
        v = state.particle_v.numpy()
        v[: model.particle_count, :2] = 0.01 * np.random.default_rng(0).standard_normal((model.particle_count, 2))
        state.particle_v.assign(v)

    model, state, speeds = advance(scene, 3000, kick)
    n = model.particle_count
    rng_v = 0.01 * np.random.default_rng(0).standard_normal((n, 2))
    ke0 = 0.5 * np.sum(rng_v**2)
    ke = 0.5 * np.sum(state.particle_v.numpy()[:n] ** 2)
    print(f"\nfree block: kinetic energy {ke / ke0:.3f} of the initial after 3000 steps")
    assert np.all(np.isfinite(speeds)) and ke <= ke0


def test_block_under_gravity_stays_bounded():
    """Sampled every 5 steps over 4 000 (0.58 s, 200 transits of the height). Measured (docs/method.md):
    the top's mean downward speed at most 0.0232 m/s against g H / c = 0.0283, and the largest speed
    0.0459 m/s at the corners, whose peak is not converged and rises as the spacing falls."""
    height = 1.0
    scene = Scene(simulation=Simulation(dim=2, dx=0.1, gravity=(0, -9.81, 0)), materials=SOIL,
                  bodies=[Body("block", "soil", min=(0, 0, 0), max=(2, height, 0))],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min")]).validate()  # fmt: skip
    bound = 9.81 * height / SOIL["soil"].p_wave_speed
    top_speeds = []

    def observe(model, state):
        n = model.particle_count
        top = np.isclose(model.particle_x0[:n, 1], height)
        top_speeds.append(-state.particle_v.numpy()[:n][top, 1].mean())

    _, _, speeds = advance(scene, 4000, every=5, observe=observe)
    print(f"\nblock under gravity: top's mean downward speed at most {max(top_speeds):.4f} m/s, largest "
          f"speed {speeds.max():.4f} m/s; 1D bound g H / c = {bound:.4f}")
    assert np.all(np.isfinite(speeds))
    assert max(top_speeds) < bound
    assert speeds.max() < 2.0 * bound


def test_geostatic_layer_under_a_free_top_stays_at_rest():
    """The surface band pushes with its particles' own traction carried to the surface by the weight
    of the soil between (taylor.py), zero on a geostatic layer. With the particles' own traction the
    row below the surface took a spurious force and the top rows kept an odd-even velocity (measured:
    2.6e-3 m/s over these 2000 steps; docs/method.md, *Known limits*)."""
    scene = Scene(simulation=Simulation(dim=2, dx=0.1, gravity=(0, -9.81, 0)), materials=SOIL,
                  bodies=[Body("layer", "soil", min=(0, 0, 0), max=(2.0, 2.2, 0), geostatic=True)],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                              Boundary("right", "slip", "x", 2.0, "max")]).validate()  # fmt: skip
    _, _, speeds = advance(scene, 2000)
    print(f"\ngeostatic layer under a free top: largest speed {speeds.max():.3g} m/s over 2000 steps")
    assert speeds.max() < 1e-10


def test_cantilever_bounded_over_its_end_time(scenes_dir):
    scene = load_scene(scenes_dir / "cantilever.toml")
    steps = int(scene.simulation.end_time / scene.time_step)
    model, state, speeds = advance(scene, steps)
    tip = np.argmin(np.sum((model.particle_x0 - [2.0, 0.25, 0.0]) ** 2, axis=1))
    deflection = state.particle_q.numpy()[tip, 1] - 0.25
    print(f"\ncantilever: {steps} steps, max speed {speeds.max():.3f} m/s, final tip deflection {deflection:.4f} m")
    # the tip swings between 0 and about twice the static deflection (about 10 mm here); speeds of a
    # 23 mm swing with a 0.16 s period stay below 1 m/s
    assert speeds.max() < 1.0 and -0.03 < deflection < 0.005
