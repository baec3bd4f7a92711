"""The water against free surfaces in mechanical phases (docs/method.md, *Reservoirs and free
surfaces*): a dry drained face carries no water load wherever it lies, a reservoir's water presses on
the faces below its level and drains into them.

- A saturated block, a drained vertical free face and a slip back, brought to equilibrium: the total
  horizontal force on the face column is zero when dry, and the water's thrust γ_w d²/2 with a
  reservoir at the block's top against the face.
- A saturated layer (incompressible water) under 1 m of water: the effective stress is the buoyant
  weight γ′ z, whatever the water depth, and the pore pressure γ_w (d + z).
"""

import h5py
import numpy as np
import pytest

from warpsph.runner import run_scene
from warpsph.scene_toml import parse_scene
from conftest import SCENES

BLOCK = """
[simulation]
dim = 2
dx = 0.25
gravity = [0, -9.81, 0]

[effects]
pore_water = true

[materials.soil]
density = 2000
youngs_modulus = 2e7
poisson_ratio = 0.3
porosity = 0.3
hydraulic_conductivity = 1e-4
water_bulk_modulus = 2.2e8
k0 = 0.5

[[bodies]]
name = "block"
material = "soil"
min = [0, 0, 0]
max = [4, 4, 0]

[[boundaries]]
name = "base"
kind = "fixed"
axis = "y"
position = 0
side = "min"

[[boundaries]]
name = "back"
kind = "slip"
axis = "x"
position = 0
side = "min"

[output]
fields = ["velocity", "stress"]
usd = false
xdmf = false

[[phases]]
name = "initial"
kind = "k0"

[[phases]]
name = "gravity"
kind = "equilibrium"
tolerance = 1e-4
"""
GAMMA_W = 1000.0 * 9.81


def last_frame(out):
    with h5py.File(out / "results.h5", "r") as f:
        frame = f["frames"][sorted(f["frames"])[-1]]
        return frame["position"][...], frame["stress"][...], frame["pore_pressure"][...]


def column_force(x, stress, pore_pressure, at, dx):
    """∫ (σ′_xx − p) dy over the particles of the column x = ``at`` [N/m] (trapezoidal)."""
    column = np.abs(x[:, 0] - at) < 0.25 * dx
    y = x[column, 1]
    ends = np.isclose(y, y.min()) | np.isclose(y, y.max())
    return float(np.sum(np.where(ends, 0.5, 1.0) * (stress[column, 0] - pore_pressure[column])) * dx)


@pytest.mark.parametrize("level", [None, 4.0])
def test_a_free_face_carries_the_water_that_stands_against_it(tmp_path, level):
    text = BLOCK
    if level is not None:
        text += (f'\n[[reservoirs]]\nname = "river"\nlevel = {level}\n'
                 "region = { min = [3, -1, -1], max = [5, 9, 1] }\n")
    run_scene(parse_scene(text, name="block"), tmp_path)
    x, stress, p = last_frame(tmp_path)
    thrust = 0.5 * GAMMA_W * 4.0**2
    expected = 0.0 if level is None else -thrust
    assert column_force(x, stress, p, 4.0, 0.25) == pytest.approx(expected, abs=0.05 * thrust)
    face = (np.abs(x[:, 0] - 4.0) < 0.05) & (x[:, 1] < 3.9)
    wet = 0.0 if level is None else GAMMA_W * (level - x[face, 1])
    np.testing.assert_allclose(p[face], wet, atol=1e-6 * thrust)  # the face drains to the water against it


LAYER = """
[simulation]
dim = 2
dx = 0.2
gravity = [0, -9.81, 0]

[effects]
pore_water = true

[materials.soil]
density = 2000
youngs_modulus = 2e7
poisson_ratio = 0.3
porosity = 0.3
hydraulic_conductivity = 1e-4
water_bulk_modulus = inf
k0 = 0.5

[[bodies]]
name = "layer"
material = "soil"
min = [0, 0, 0]
max = [1, 2, 0]

[[boundaries]]
name = "base"
kind = "fixed"
axis = "y"
position = 0
side = "min"

[[boundaries]]
name = "left"
kind = "slip"
axis = "x"
position = 0
side = "min"

[[boundaries]]
name = "right"
kind = "slip"
axis = "x"
position = 1
side = "max"

[[reservoirs]]
name = "lake"
level = 3.0

[output]
fields = ["velocity", "stress"]
usd = false
xdmf = false

[[phases]]
name = "initial"
kind = "k0"

[[phases]]
name = "gravity"
kind = "equilibrium"
tolerance = 1e-5
"""


def test_a_submerged_layer_carries_its_buoyant_weight(tmp_path):
    run_scene(parse_scene(LAYER, name="lake"), tmp_path)
    x, stress, p = last_frame(tmp_path)
    depth = 2.0 - x[:, 1]
    buoyant = (2000.0 - 1000.0) * 9.81
    inside = depth > 0.3
    np.testing.assert_allclose(p, GAMMA_W * (1.0 + depth), atol=5e-3 * GAMMA_W * 3.0)
    np.testing.assert_allclose(stress[inside, 1], -buoyant * depth[inside], rtol=0.02)


@pytest.mark.parametrize("suction", ["ignored", "counted"])
def test_fixed_pore_pressures_carry_bishops_chi(tmp_path, suction):
    """A phase with fixed pore pressures keeps them bit for bit, and its total stress carries χ p_w: the
    held excess pressure of a particle under suction is χ p_w − p_h, with χ = S_e where suction is
    counted and 0 where it is ignored (the default)."""
    import warp as wp

    from warpsph.physics.retention import retention_state

    text = (BLOCK.replace("water_bulk_modulus = 2.2e8", 'water_bulk_modulus = inf\nretention = "van_genuchten"\n'
                          "retention_alpha = 1.0\nretention_n = 2.0\nresidual_saturation = 0.2")
            .replace("k0 = 0.5\n", f"k0 = 0.5\n\n[pressure]\nwater_table = 2.0\nsuction = {suction!r}\n")
            .replace('kind = "equilibrium"\n', 'kind = "equilibrium"\npore_pressure = "fixed"\n'))  # fmt: skip
    from warpsph.runner import Run

    run = Run(parse_scene(text, name="block"), tmp_path)
    start = run.state.particle_pore_pressure.numpy().copy()
    run.run()
    assert run.records[-1].outcome == "converged"
    np.testing.assert_array_equal(run.state.particle_pore_pressure.numpy()[: len(start)], start)
    held = run.solver.held_pressure.numpy()[: run.model.particle_count]
    y = run.model.particle_x0[:, 1]
    total = GAMMA_W * (2.0 - y)  # hydrostatic about the water table at 2 m: suction above it
    f64 = wp.float64
    for i in np.argsort(y)[-3:]:
        s, _slope, _kr = retention_state(1, f64(1.0), f64(2.0), f64(0.2), f64(GAMMA_W), f64(total[i]))
        chi = (float(s) - 0.2) / 0.8 if suction == "counted" else 0.0
        assert chi < 0.9
        assert held[i] == pytest.approx(chi * total[i] - total[i], rel=1e-9)


def test_a_reservoir_beside_no_surface_is_refused_in_a_mechanical_phase(tmp_path):
    from warpsph.errors import SceneError

    text = LAYER.replace('level = 3.0\n', 'level = 3.0\nregion = { min = [5, -1, -1], max = [6, 9, 1] }\n')
    with pytest.raises(SceneError, match=r"reservoirs.lake.region.*touches no surface"):
        run_scene(parse_scene(text, name="lake"), tmp_path)



def griffiths_and_lane(water: str, safety: bool, density: float = 1038.7) -> str:
    """scenes/slope_fos.toml without its run-out (and without its safety phase unless ``safety``), ``water``:
    "dry" at ``density`` (by default the buoyant γ_sat − γ_w); saturated (porosity 0.4) with its pore
    pressures held, "submerged" under 14 m of still water after a steady flow phase, or with a "water_table"
    1 m up its 2 m foundation."""
    text = (SCENES / "slope_fos.toml").read_text()
    last = '[[phases]]\nname = "runout"' if safety else '[[phases]]\nname = "safety"'
    text = text[: text.index(last)] + text[text.index("[[probes]]") :]
    if water == "dry":
        return text.replace("density = 2038.7", f"density = {density}")
    text = (text.replace("plasticity = true", "plasticity = true\npore_water = true")
            .replace("dilatancy_angle = 0.0", "dilatancy_angle = 0.0\nporosity = 0.4\nwater_bulk_modulus = inf\n"
                     "hydraulic_conductivity = 1e-6")
            .replace('kind = "equilibrium"', 'kind = "equilibrium"\npore_pressure = "fixed"')
            .replace('kind = "safety"', 'kind = "safety"\npore_pressure = "fixed"'))  # fmt: skip
    if water == "water_table":
        return text.replace('[[phases]]\nname = "initial"',
                            '[pressure]\nwater_table = 1.0\n\n[[phases]]\nname = "initial"')
    return (text.replace('[[phases]]\nname = "initial"', '[[reservoirs]]\nname = "lake"\nlevel = 14.0\n\n'
                         '[[phases]]\nname = "initial"')
            .replace('[[phases]]\nname = "gravity"', '[[phases]]\nname = "flow"\nkind = "flow"\nsteady = true\n\n'
                     '[[phases]]\nname = "gravity"'))  # fmt: skip


def test_a_submerged_slope_under_held_pore_pressures_is_loaded_as_its_buoyant_dry_twin(tmp_path):
    """Under still water the skeleton carries γ_sat − γ_w: held at rest, Griffiths & Lane's slope under 14 m
    of water stands with the effective stresses of the same slope dry at the buoyant density, at its face
    and toe too (the free surface pushes as a dry one does while the pore pressures are held,
    docs/method.md, *Drained free surfaces*)."""
    fields = {}
    for name in ("submerged", "buoyant"):
        water = "submerged" if name == "submerged" else "dry"
        run_scene(parse_scene(griffiths_and_lane(water, safety=False), name=name), tmp_path / name)
        with h5py.File(tmp_path / name / "results.h5", "r") as f:
            frame = f["frames"][sorted(f["frames"])[-1]]
            order = np.argsort(frame["id"][...])
            fields[name] = frame["stress"][...][order]
    wet, dry = fields["submerged"], fields["buoyant"]
    largest = np.abs(dry[:, 1]).max()
    print(f"\nlargest difference {np.abs(wet - dry).max() / largest:.4f} of the largest stress")
    assert np.abs(wet - dry).max() < 0.02 * largest  # 0.37 %; with the drained surface's extrapolation 4.3 %


def test_ground_above_the_water_table_under_held_pore_pressures_is_loaded_as_dry_ground(tmp_path):
    """Above the water table held pore pressures carry nothing (suction ignored): Griffiths & Lane's slope
    with its water table 1 m up its foundation, brought to rest, has there the effective stresses of the same
    slope dry, at its inclined face too (the surface band takes the pore pressure at the surface and the
    weight the effective stress carries, docs/method.md, *Drained free surfaces*)."""
    fields = {}
    for water in ("water_table", "dry"):
        run_scene(parse_scene(griffiths_and_lane(water, safety=False, density=2038.7), name=water), tmp_path / water)
        with h5py.File(tmp_path / water / "results.h5", "r") as f:
            frame = f["frames"][sorted(f["frames"])[-1]]
            order = np.argsort(frame["id"][...])
            fields[water] = frame["stress"][...][order], frame["position"][...][order]
    (wet, x), (dry, _) = fields["water_table"], fields["dry"]
    above = x[:, 1] > 1.5
    largest = np.abs(dry[:, 1]).max()
    print(f"\nlargest difference above the water table {np.abs(wet - dry)[above].max() / largest:.2e} of the "
          f"largest stress")
    assert np.abs(wet - dry)[above].max() < 1e-2 * largest  # 0.37 %; 2.7 % with the point's own pressure


def test_limit_equilibrium_counts_suction_where_the_phase_does(tmp_path):
    """The safety phase's limit equilibrium takes the pore pressures its effective stress carries: above the
    water table of Griffiths & Lane's slope (1 m up its foundation) none where suction is ignored (the default),
    χ p_w where it is counted (χ = S_e: 1 for the saturated retention, less for van Genuchten's loam), which
    raises Bishop's factor."""
    from warpsph.runner import Run

    loam = 'retention = "van_genuchten"\nretention_alpha = 3.6\nretention_n = 1.56\nresidual_saturation = 0.18\n'
    factors = {}
    for name, suction, retention in (("ignored", "ignored", ""), ("loam", "counted", loam),
                                     ("saturated", "counted", "")):  # fmt: skip
        text = (griffiths_and_lane("water_table", safety=True)
                .replace("water_table = 1.0\n", f"water_table = 1.0\nsuction = {suction!r}\n")
                .replace("hydraulic_conductivity = 1e-6\n", "hydraulic_conductivity = 1e-6\n" + retention))  # fmt: skip
        scene = parse_scene(text, name=name)
        scene.phases = [phase for phase in scene.phases if phase.kind == "safety"]
        run = Run(scene, tmp_path / name)
        run.calculation.limit_equilibrium(run.records[-1])
        factors[name] = run.records[-1].limit_equilibrium[0]
    print(f"\nBishop's factor with suction ignored {factors['ignored']:.3f}, counted in loam {factors['loam']:.3f}, "
          f"counted saturated {factors['saturated']:.3f}")
    assert factors["ignored"] + 0.01 < factors["loam"] < factors["saturated"] - 0.01


@pytest.mark.slow
def test_griffiths_and_lanes_slope_under_water_has_the_factor_of_safety_of_its_buoyant_dry_twin(tmp_path):
    """Strength reduction under 14 m of still water, the pore pressures held, against the same slope dry
    at γ_sat − γ_w: limit equilibrium gives the two one factor and strength reduction must too, within the
    two searches' brackets (measured 1.717 ± 0.006 and 1.705 ± 0.006; with the drained surface's
    extrapolation the submerged slope stood at 1.875)."""
    found = {}
    for name in ("submerged", "buoyant"):
        scene = parse_scene(griffiths_and_lane("submerged" if name == "submerged" else "dry", safety=True), name=name)
        phase = run_scene(scene, tmp_path / name).phases[-1]
        found[name] = phase["criterion"], phase["resolution"]
    (wet, wet_resolution), (dry, dry_resolution) = found["submerged"], found["buoyant"]
    print(f"\nfactor of safety under water {wet:.3f} ± {wet_resolution:.3f}, dry and buoyant {dry:.3f} ± "
          f"{dry_resolution:.3f}")
    assert abs(wet - dry) <= wet_resolution + dry_resolution + 0.01
