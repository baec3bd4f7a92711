"""Staged analysis: phases run in order, each from the state the one before left.

- The K0 procedure sets layered ground's geostatic stresses at once: σ′_v = Σγh from the top of
  each particle's column, σ′_h = K0 σ′_v; a slope's toe carries its own cover, not the crest's. With
  pore water σ′_v is the total weight less Bishop's χ p_w, so ground with a water table below its
  surface starts at rest.
- Gravity loading (an equilibrium phase with local damping, from zero stress) brings elastic
  layered ground to rest: the base reaction equals the weight, σ′_h/σ′_v = ν/(1 − ν), σ′_v = Σγh.
- The results record the phases; frames carry their phase; a run stopped inside a phase and resumed
  ends bit-identical to one that ran through.
- Bad phases get one line naming the key path.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import warpsph
from warpsph import Body, Boundary, Load, Material, Probe, Scene, SceneError, Simulation
from warpsph.scene import Phase, TimeFunction

G = 9.81
DX = 0.2
TOP, MIDDLE = 3.0, 1.6  # the ground surface and the layers' interface [m]
RHO_UPPER, RHO_LOWER = 1800.0, 2000.0


def layered_ground(phases, loads=(), **simulation) -> Scene:
    """Two elastic layers 1.4 m and 1.6 m thick on a fixed base, slip sides, 2 m wide."""
    materials = {"upper": Material("upper", density=RHO_UPPER, youngs_modulus=2e7, poisson_ratio=0.3, k0=0.5),
                 "lower": Material("lower", density=RHO_LOWER, youngs_modulus=4e7, poisson_ratio=0.25, k0=0.6)}
    scene = Scene(name="layers", simulation=Simulation(dim=2, dx=DX, end_time=1.0, gravity=(0.0, -G, 0.0),
                                                       **simulation),
                  materials=materials,
                  bodies=[Body("upper", "upper", min=(0, MIDDLE, 0), max=(2.0, TOP, 0)),
                          Body("lower", "lower", min=(0, 0, 0), max=(2.0, MIDDLE, 0))],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                              Boundary("right", "slip", "x", 2.0, "max")],
                  loads=list(loads), probes=[Probe("base_reaction", kind="reaction", field="y", boundary="base")],
                  phases=phases)  # fmt: skip
    scene.output.usd = scene.output.xdmf = False
    scene.output.frame_interval = 1e3
    return scene.validate()


def overburden(y: np.ndarray) -> np.ndarray:
    """σ_v [Pa] of the lattice's layers: the upper body's rows reach down to the interface's row, so
    the lower layer starts half a spacing below it."""
    interface = MIDDLE - 0.5 * DX
    upper = RHO_UPPER * G * (TOP - np.maximum(y, interface))
    return -(upper + RHO_LOWER * G * np.maximum(interface - y, 0.0))


def test_k0_procedure_sets_layered_geostatic_stresses(tmp_path):
    scene = layered_ground([Phase("initial", kind="k0")])
    summary = warpsph.run_scene(scene, tmp_path, device="cpu")
    assert summary.steps == 0 and summary.phases[0]["outcome"] == "converged"
    frame = warpsph.load_results(tmp_path / "results.h5").frame(-1)
    y, stress = frame["position"][:, 1], frame["stress"]
    deep = y < TOP - 2 * DX
    assert np.max(np.abs(stress[:, 1] - overburden(y))[deep] / np.abs(overburden(y)[deep])) < 1e-9
    k0 = np.where(y >= MIDDLE - 1e-9, 0.5, 0.6)
    assert np.allclose(stress[:, 0], k0 * stress[:, 1]) and np.allclose(stress[:, 2], k0 * stress[:, 1])


@pytest.mark.parametrize("suction", ["ignored", "counted"])
def test_k0_procedure_under_a_water_table_leaves_the_ground_at_rest(tmp_path, suction):
    """σ′_v = σ_v + χ p_w: 3 m of loam with its water table 1.5 m down carries its total weight less
    χ p_w (χ = 1 below the water table; above it 0, or with suction counted S_e of van Genuchten's
    curve), so the equilibrium phase that follows, holding the pore pressures, finds the ground at rest."""
    loam = dict(density=2000.0, porosity=0.4, hydraulic_conductivity=1e-6, water_bulk_modulus=math.inf,
                retention="van_genuchten", retention_alpha=3.6, retention_n=1.56, residual_saturation=0.18)
    scene = layered_ground([Phase("initial", kind="k0")])
    scene.phases.append(Phase("gravity", kind="equilibrium", pore_pressure="fixed"))
    scene.materials = {name: dataclasses.replace(mat, **loam) for name, mat in scene.materials.items()}
    scene.effects = dataclasses.replace(scene.effects, pore_water=True)
    scene.pressure = dataclasses.replace(scene.pressure, water_table=1.5, suction=suction)
    scene.output.fields = ["stress", "displacement"]
    summary = warpsph.run_scene(scene.validate(), tmp_path, device="cpu")
    results = warpsph.load_results(tmp_path / "results.h5")
    k0, rest = results.frame(0), results.frame(-1)
    y = k0["position"][:, 1]
    p = 1000.0 * G * (1.5 - y)
    suction_head = np.maximum(-p, 0.0) / (1000.0 * G)
    chi = (1.0 + (3.6 * suction_head) ** 1.56) ** (1.0 / 1.56 - 1.0) if suction == "counted" else p >= 0.0
    expected = -2000.0 * G * (y.max() - y) + chi * p
    assert np.max(np.abs(k0["stress"][:, 1] - expected)) < 1e-9 * 2000.0 * G * TOP
    assert summary.phases[1]["outcome"] == "converged" and summary.phases[1]["steps"] <= 20
    assert np.max(np.abs(rest["displacement"])) < 1e-9


def test_geostatic_depth_is_measured_up_each_column():
    """A 1:1 slope's toe is loaded by the soil above the toe, not by the crest's height."""
    from warpsph.builder import build

    scene = layered_ground([])
    scene.bodies = [Body("slope", "upper", shape="polygon", vertices=[(0, 0), (4, 0), (4, 3), (3, 3), (1, 1), (0, 1)],
                         geostatic=True)]  # fmt: skip
    scene.boundaries[2].position = 4.0
    model, state = build(scene.validate(), device="cpu")
    x0 = model.particle_x0
    sigma = state.particle_stress.numpy()[: model.particle_count, 1, 1]
    for x in (0.4, 2.0, 3.6):
        column = np.abs(x0[:, 0] - x) < 1e-9
        top = x0[column, 1].max()
        expected = -RHO_UPPER * G * (top - x0[column, 1])
        assert np.allclose(sigma[column], expected), x


@pytest.fixture(scope="module")
def gravity_loading(tmp_path_factory):
    out = tmp_path_factory.mktemp("gravity")
    scene = layered_ground([Phase("gravity", kind="equilibrium", tolerance=1e-4, max_steps=20000)])
    summary = warpsph.run_scene(scene, out, device="cpu")
    return scene, summary, warpsph.load_results(out / "results.h5")


def test_gravity_loading_reaches_equilibrium(gravity_loading):
    scene, summary, results = gravity_loading
    phase = summary.phases[0]
    print(f"\ngravity loading: {phase['outcome']} after {phase['steps']} steps, ratio {phase['criterion']:.3g}")
    assert phase["outcome"] == "converged" and phase["criterion"] < 1e-4
    weight = sum(scene.materials[b.material].density * G * 2.0 * (b.max[1] - b.min[1]) for b in scene.bodies)
    _, reaction = results.series("base_reaction")
    print(f"base reaction / weight: {reaction[-1] / weight:.5f}")
    assert reaction[-1] == pytest.approx(weight, rel=5e-3)


def test_gravity_loading_gives_the_elastic_geostatic_stresses(gravity_loading):
    """σ′_h/σ′_v = ν/(1 − ν) in each layer within 1 %; σ′_v within 1 % of Σγh in the mean of each two
    neighbouring rows of a layer, and within 1 % of ρgH at every row (0.6 % measured: the phase's velocity
    filter keeps the reals' odd-even mode, which no virtual point sees, from taking up the release of
    gravity)."""
    _, _, results = gravity_loading
    frame = results.frame(-1)
    x, y, stress = frame["position"][:, 0], frame["position"][:, 1], frame["stress"]
    column = (np.abs(x - 1.0) < 0.5 * DX) & (y < TOP - 2.5 * DX) & (y > 1.5 * DX)
    order = np.argsort(y[column])
    ys, syy, sxx = y[column][order], stress[column, 1][order], stress[column, 0][order]
    upper = ys >= MIDDLE - 0.5 * DX
    same_layer = upper[1:] == upper[:-1]
    pair_mean, expected = 0.5 * (syy[1:] + syy[:-1]), 0.5 * (overburden(ys[1:]) + overburden(ys[:-1]))
    local = np.max(np.abs(pair_mean - expected)[same_layer] / np.abs(expected[same_layer]))
    scale = RHO_UPPER * G * (TOP - MIDDLE) + RHO_LOWER * G * MIDDLE
    pointwise = np.max(np.abs(syy - overburden(ys))) / scale
    nu = np.where(upper, 0.3, 0.25)
    ratio_error = np.max(np.abs(sxx / syy - nu / (1 - nu)) / (nu / (1 - nu)))
    print(f"sigma_v: two-row means within {local:.4f} of the local value, rows within {pointwise:.4f} of rho g H; "
          f"sigma_h/sigma_v within {ratio_error:.1e}")
    assert local < 0.01 and pointwise < 0.01
    assert ratio_error < 0.01


SLOPE = [(0, 0), (8, 0), (8, 3), (6, 3), (2, 1), (0, 1)]  # a 2:1 slope 2 m high on 1 m of ground [m]
SLOPE_WEIGHT = 2000.0 * G * 16.0  # ρ g times the polygon's area [N/m]


def uniform_ground(vertices, width: float) -> Scene:
    """One elastic soil (ρ = 2000 kg/m³, E = 20 MPa, ν = 0.3) filling the polygon ``vertices`` on the fixed
    base, slip sides at x = 0 and ``width``, brought to rest under gravity (ratio 1e-5)."""
    scene = layered_ground([Phase("gravity", kind="equilibrium", tolerance=1e-5, max_steps=5000)])
    scene.materials = {"soil": Material("soil", density=2000.0, youngs_modulus=2e7, poisson_ratio=0.3)}
    scene.bodies = [Body("ground", "soil", shape="polygon", vertices=vertices)]
    scene.boundaries[2].position = width
    scene.output.fields = ["stress", "displacement"]
    return scene.validate()


def test_base_reaction_of_level_ground_equals_its_weight(tmp_path):
    """Level ground 2 m wide and 3 m deep of one soil at rest: the reaction probe (the base's traction
    integrated over the plane's current tributary areas) reads its weight within 0.1 % (+0.05 %
    measured; each particle's volume over the spacing, V/Δx, as its area would read −0.17 %, the base
    row's compression counted as area)."""
    summary = warpsph.run_scene(uniform_ground([(0, 0), (2, 0), (2, TOP), (0, TOP)], 2.0), tmp_path, device="cpu")
    _, reaction = warpsph.load_results(tmp_path / "results.h5").series("base_reaction")
    weight = 2000.0 * G * 2.0 * TOP
    print(f"\n{summary.phases[0]['outcome']}; base reaction / weight {reaction[-1] / weight:.5f}")
    assert summary.phases[0]["outcome"] == "converged"
    assert reaction[-1] == pytest.approx(weight, rel=1e-3)


@pytest.fixture(scope="module")
def elastic_slope(tmp_path_factory):
    out = tmp_path_factory.mktemp("slope")
    summary = warpsph.run_scene(uniform_ground(SLOPE, 8.0), out, device="cpu")
    return summary.phases[0], warpsph.load_results(out / "results.h5")


def test_gravity_loading_of_an_elastic_slope_matches_finite_elements(elastic_slope):
    """A 2:1 elastic slope brought to rest under gravity against a plane-strain P2 finite-element
    solution of the same polygon (tests/fe_reference.py): every stress component of every particle
    more than 2.5 Δx inside the body within 5 % of ρg(H + D), the base reaction within 2 % of the
    finite elements' (+1.5 % measured: the slope's own excess, below)."""
    from fe_reference import _boundary_distance, elastic_gravity_state

    phase, results = elastic_slope
    frame = results.frame(-1)
    start = (frame["position"] - frame["displacement"])[:, :2]
    inner = _boundary_distance(np.asarray(SLOPE, float), start) > 2.5 * DX
    fe = elastic_gravity_state(SLOPE, youngs_modulus=2e7, poisson_ratio=0.3, density=2000.0, element_size=0.1,
                               points=start[inner])  # fmt: skip
    sph = frame["stress"][inner][:, [0, 1, 5]]
    error = np.max(np.abs(sph - fe["stress"]), axis=0) / (2000.0 * G * 3.0)
    _, reaction = results.series("base_reaction")
    print(f"\nslope: {phase['outcome']} after {phase['steps']} steps, ratio {phase['criterion']:.3g}; largest "
          f"errors xx, yy, xy {np.array2string(error, precision=4)} of rho g (H + D); base reaction / FE's "
          f"{reaction[-1] / fe['base_reaction_y']:.4f}")
    assert phase["outcome"] == "converged"
    assert np.all(error < 0.05)
    assert reaction[-1] == pytest.approx(fe["base_reaction_y"], rel=0.02)


@pytest.mark.xfail(strict=True, reason=(
    "the SPH slope at rest carries more than its weight: its base reaction is +1.52, +0.67 and +0.30 % "
    "above it at dx = 0.2, 0.1 and 0.05 m, and every row from the base to 0.6 m carries the same excess "
    "(2.09-2.14 kN/m at dx = 0.1 m), a load its inclined face's surface band adds (docs/method.md, "
    "Known limits)"))  # fmt: skip
def test_elastic_slope_base_reaction_equals_its_weight(elastic_slope):
    """The issue's criterion: the 2:1 slope at rest, its base reaction equal to its weight ρ g A within
    0.1 %."""
    _, results = elastic_slope
    _, reaction = results.series("base_reaction")
    print(f"\nbase reaction / weight {reaction[-1] / SLOPE_WEIGHT:.5f}")
    assert reaction[-1] == pytest.approx(SLOPE_WEIGHT, rel=1e-3)


def staged_scene(**phase_changes):
    """K0, a surcharge activated under an equilibrium phase, then a dynamic phase from it with the
    displacements reset."""
    surcharge = Load("surcharge", kind="traction", axis="y", position=TOP, side="max", traction=(0.0, -1e4, 0.0),
                     time_function=TimeFunction("ramp", duration=0.05))  # fmt: skip
    phases = [Phase("initial", kind="k0"),
              Phase("surcharge", kind="equilibrium", activate=["surcharge"], tolerance=1e-3, **phase_changes),
              Phase("shake", kind="dynamic", duration=0.03, reset_displacements=True,
                    changes={"loads.surcharge.traction": [0.0, -2e4, 0.0]})]  # fmt: skip
    scene = layered_ground(phases, loads=[surcharge])
    scene.output.frame_interval = 0.01
    scene.output.fields = ["velocity", "stress", "displacement"]
    return scene.validate()


@pytest.fixture(scope="module")
def staged_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("staged")
    scene = staged_scene()
    summary = warpsph.run_scene(scene, out, device="cpu")
    return scene, summary, out


def test_phases_are_recorded(staged_run):
    scene, summary, out = staged_run
    results = warpsph.load_results(out / "results.h5")
    phases = results.phases
    assert [p["name"] for p in phases] == ["initial", "surcharge", "shake"]
    assert [p["outcome"] for p in phases] == ["converged", "converged", "finished"]
    assert phases[0]["last_step"] == phases[1]["first_step"] == 0
    assert phases[1]["last_step"] == phases[2]["first_step"] > 0
    assert phases[2]["end_time"] == pytest.approx(phases[2]["start_time"] + 0.03, abs=scene.time_step)
    frame_phases = results.frame_phases
    assert frame_phases[0] == 0 and frame_phases[-1] == 2 and np.all(np.diff(frame_phases) >= 0)
    assert np.all(np.diff(results.times) >= 0)
    first_shake = results.frame(int(np.argmax(frame_phases == 2)))
    assert np.all(first_shake["displacement"] == 0.0)  # reset at the start of the phase
    assert summary.status == "finished"


def test_stop_and_resume_across_phases_is_bit_identical(staged_run, tmp_path):
    scene, _, out = staged_run
    reference = warpsph.load_results(out / "results.h5")
    stop_equilibrium = reference.phases[1]["start_time"] + 0.4 * (reference.phases[1]["end_time"]
                                                                  - reference.phases[1]["start_time"])
    warpsph.run_scene(scene, tmp_path, device="cpu", end_time=stop_equilibrium)
    warpsph.run_scene(scene, tmp_path, device="cpu", end_time=reference.phases[2]["start_time"] + 0.015,
                      resume=True)  # fmt: skip
    warpsph.run_scene(scene, tmp_path, device="cpu", resume=True)
    resumed = warpsph.load_results(tmp_path / "results.h5")
    assert [p["outcome"] for p in resumed.phases] == ["converged", "converged", "finished"]
    for key in ("position", "velocity", "stress", "displacement"):
        assert np.array_equal(resumed.frame(-1)[key], reference.frame(-1)[key]), key
    assert resumed.phases[2]["last_step"] == reference.phases[2]["last_step"]


def test_equilibrium_that_cannot_converge_in_its_cap_says_so(tmp_path):
    scene = layered_ground([Phase("gravity", kind="equilibrium", max_steps=30),
                            Phase("after", kind="dynamic", duration=0.01)])  # fmt: skip
    summary = warpsph.run_scene(scene, tmp_path, device="cpu")
    assert summary.status == "not converged" and [p["name"] for p in summary.phases] == ["gravity"]
    assert summary.phases[0]["outcome"] == "not converged"


@pytest.mark.parametrize("change, key, words", [
    ({"kind": "static"}, "phases.gravity.kind", "must be one of"),
    ({"activate": ["nothing"]}, "phases.gravity.activate[0]", "no body, load or boundary"),
    ({"deactivate": ["upper", "lower"]}, "phases.gravity.deactivate", "no body active"),
    ({"tolerance": 0.0}, "phases.gravity.tolerance", "must be"),
    ({"changes": {"materials.clay.cohesion": 1e3}}, "phases.gravity.changes.materials.clay.cohesion",
     "no materials.clay"),
    ({"changes": {"bodies.upper.material": "clay"}}, "phases.gravity", "unknown material"),
])  # fmt: skip
def test_bad_phases_name_their_key(change, key, words):
    scene = layered_ground([])
    scene.phases = [Phase("initial", kind="k0"), dataclasses.replace(Phase("gravity", kind="equilibrium"), **change)]
    with pytest.raises(SceneError) as err:
        scene.validate()
    assert str(err.value).startswith(key) and words in str(err.value) and "\n" not in str(err.value)


def test_equilibrium_without_gravity_or_load_is_refused():
    scene = layered_ground([Phase("gravity", kind="equilibrium")], )
    scene.simulation.gravity = (0.0, 0.0, 0.0)
    with pytest.raises(SceneError, match="would do nothing"):
        scene.validate()


def test_phases_from_a_scene_file(tmp_path):
    text = """
[simulation]
dim = 2
dx = 0.25
gravity = [0, -9.81]
[materials.soil]
youngs_modulus = 2e7
[[bodies]]
name = "ground"
material = "soil"
max = [2, 2]
[[boundaries]]
name = "base"
kind = "fixed"
[[phases]]
name = "initial"
kind = "k0"
[[phases]]
name = "stiffer"
kind = "dynamic"
duration = 0.01
changes = { "materials.soil.youngs_modulus" = 4e7 }
"""
    scene = warpsph.parse_scene(text)
    assert [p.kind for p in scene.phases] == ["k0", "dynamic"]
    from warpsph.phases import phase_scene

    assert phase_scene(scene, 1).materials["soil"].youngs_modulus == 4e7
    assert phase_scene(scene, 0).materials["soil"].youngs_modulus == 2e7
    assert scene.materials["soil"].youngs_modulus == 2e7


def test_a_phase_the_guard_stops_is_recorded_unstable(tmp_path):
    """A speed bound below what the surcharge's first steps give: the guard stops the run in the
    equilibrium phase, which ``/phases`` records as ``unstable`` with the step it stopped at."""
    scene = staged_scene()
    scene.simulation.velocity_limit = 1e-9
    with pytest.raises(warpsph.SimulationError, match=r"unstable at step \d+ \(phase surcharge\)"):
        warpsph.run_scene(scene.validate(), tmp_path, device="cpu")
    phases = warpsph.load_results(tmp_path / "results.h5").phases
    assert [(p["name"], p["outcome"]) for p in phases] == [("initial", "converged"), ("surcharge", "unstable")]
    assert phases[1]["last_step"] > phases[1]["first_step"] >= 0


def test_each_phase_reports_as_it_ends(tmp_path):
    """``Run.run(phase_done=...)`` hands each phase's result over as the phase ends, before the next
    phase takes a step (the command line prints it then, not when the whole run ends)."""
    from warpsph.runner import Run

    run = Run(staged_scene(), tmp_path, device="cpu")
    reported = []
    run.run(phase_done=lambda p: reported.append((p["name"], p["outcome"], run.step_index)))
    phases = warpsph.load_results(tmp_path / "results.h5").phases
    assert [(name, outcome) for name, outcome, _ in reported] == [(p["name"], p["outcome"]) for p in phases]
    assert [step for *_, step in reported] == [p["last_step"] for p in phases]
    assert reported[1][2] < phases[2]["last_step"]


def lifted_ground(probe_point) -> Scene:
    """The layered ground built in two phases: K0 on the lower layer, then the upper layer placed on it
    (an equilibrium phase), with a point probe at ``probe_point``."""
    scene = layered_ground([Phase("initial", kind="k0", deactivate=["upper"]),
                            Phase("lift", kind="equilibrium", activate=["upper"], tolerance=1e-2, max_steps=40)])
    scene.probes.append(Probe("lift_top", kind="point", field="displacement_y", point=probe_point))
    return scene.validate()


def test_a_probe_samples_in_the_phases_whose_particles_it_reaches(tmp_path):
    """A point probe on a layer that a later phase places is checked against that phase's particles, not
    the first's: validate accepts it and reports each phase's particles, the run samples it from the phase
    that places the layer on; a probe that no phase's particles reach is refused, naming its key."""
    from warpsph.planning import plan

    scene = lifted_ground((1.0, TOP - 0.5 * DX, 0.0))
    lines = plan(scene, "cpu", timed=False).lines()
    assert lines[0].startswith("176 particles (99 in initial, 176 in lift)")  # 11 columns of 9 rows, then 16
    summary = warpsph.run_scene(scene, tmp_path, device="cpu")
    results = warpsph.load_results(tmp_path / "results.h5")
    times, _ = results.series("lift_top")
    lift_start = summary.phases[0]["steps"]  # the K0 phase takes no step: the lift starts at t = 0
    assert len(times) >= 2 and lift_start == 0
    assert len(results.series("base_reaction")[0]) > len(times)  # the base reaction samples the K0 phase too
    with pytest.raises(SceneError, match=r"probes\.lift_top\.point: the nearest particle in any phase is 1 m away"):
        plan(lifted_ground((1.0, TOP + 1.0, 0.0)), "cpu", timed=False)
    with pytest.raises(SceneError, match=r"probes\.lift_top\.point"):
        warpsph.run_scene(lifted_ground((1.0, TOP + 1.0, 0.0)), tmp_path / "refused", device="cpu")


def test_a_load_is_checked_in_the_phase_it_acts_in():
    """validate builds every phase: a traction that a later phase activates on a face where no particle
    lies is refused before the run, naming its key, not when the run reaches that phase."""
    from warpsph.planning import plan

    scene = lifted_ground((1.0, 1.0, 0.0))
    scene.loads.append(Load("stray", kind="traction", axis="y", position=TOP + 1.0, side="max",
                            traction=(0.0, -1e3, 0.0)))  # fmt: skip
    scene.phases.append(Phase("load", kind="equilibrium", activate=["stray"], tolerance=1e-2, max_steps=40))
    with pytest.raises(SceneError, match=r"loads\.stray\.position: no particle lies on this traction face"):
        plan(scene.validate(), "cpu", timed=False)


def test_a_partial_traction_load_scales_the_ratio_by_the_particles_it_loads(tmp_path):
    """The unbalanced-force ratio's load is a traction's resultant over the particles inside its
    extent: a strip over a quarter of a layer's top loads 4 of the face's 13 particles."""
    from warpsph.phases.equilibrium import loaded_particles
    from warpsph.runner import Run
    from warpsph.stability.water import strip_loaded_layer

    model = Run(strip_loaded_layer(), tmp_path).model
    strip = model.plane_names.index("strip")
    on_face = np.any(model.constraint_planes.numpy().reshape(-1, 3) == strip, axis=1)
    assert loaded_particles(model, strip) == 4 and np.count_nonzero(on_face) == 13
