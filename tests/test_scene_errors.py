"""Scene file parsing and validation: every bad input names its key path; lattice filling counts."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from warpsph.errors import SceneError, SceneWarning
from warpsph.lattice import count_lattice_points, fill_body, fill_cells
from warpsph.scene import Body, Material, Scene, Simulation
from warpsph.scene_toml import load_scene, parse_scene

BASE = """
name = "column"

[simulation]
dim = 2
dx = 0.1
end_time = 0.5
smoothing_ratio = 1.3
kernel = "cubic_spline"
scheme = "two_set"
gravity = [0, -9.81]

[effects]
pore_water = false

[materials.soil]
model = "elastic"
density = 2000
youngs_modulus = 1e7
poisson_ratio = 0.3

[[bodies]]
name = "column"
material = "soil"
shape = "box"
min = [0, 0]
max = [0.5, 2.0]

[[boundaries]]
name = "base"
kind = "fixed"
axis = "y"
position = 0.0
side = "min"

[[boundaries]]
name = "left"
kind = "slip"
axis = "x"
position = 0.0
side = "min"

[[loads]]
name = "top"
kind = "traction"
axis = "y"
position = 2.0
side = "max"
traction = [0, -1e4]
time_function = { kind = "table", times = [0.0, 0.1, 0.2], values = [0.0, 1.0, 1.0] }

[[probes]]
name = "base_force"
kind = "reaction"
boundary = "base"
field = "y"

[[probes]]
name = "middle"
kind = "point"
field = "stress_yy"
point = [0.25, 1.0]

[output]
frame_interval = 0.01
fields = ["velocity", "stress"]
"""

SECOND_BODY = """
[[bodies]]
name = "column"
material = "soil"
min = [1, 0]
max = [2, 1]
"""

TRIANGLE_IN_3D = """
[[bodies]]
name = "wedge"
material = "soil"
shape = "polygon"
vertices = [[0, 0], [1, 0], [0, 1]]
"""


def edit(old: str, new: str):
    """A case that replaces the unique text ``old`` of the base scene by ``new``."""

    def apply(text: str) -> str:
        assert text.count(old) == 1, old
        return text.replace(old, new)

    return apply


def append(extra: str):
    return lambda text: text + extra


def material_key(line: str):
    """A case that adds ``line`` to the material table of the base scene."""
    return edit("poisson_ratio = 0.3", f"poisson_ratio = 0.3\n{line}")


def base_drainage(table: str):
    """A case that gives the base boundary the drainage ``table``."""
    return edit('kind = "fixed"', f'kind = "fixed"\ndrainage = {table}')


PORE_WATER = edit("pore_water = false", "pore_water = true")
PLASTICITY = edit("pore_water = false", "plasticity = true")
VISCOPLASTIC = edit('model = "elastic"', 'model = "viscoplastic"\ncohesion = 1e4')


def chain(*edits):
    def apply(text: str) -> str:
        for e in edits:
            text = e(text)
        return text

    return apply


RIGID = '\n[[loads]]\nname = "cap"\nkind = "{kind}"\n{extra}\n'
"""A rigid load appended to BASE (``{kind}``, ``{extra}`` keys)."""

BAD_CASES = {
    "two records on one face": (append('\n[[boundaries]]\nname = "lid"\nkind = "free"\naxis = "y"\nposition = 2.0\n'
                                       'side = "max"\n'), "loads.top"),
    "pore water with the collocated scheme": (chain(PORE_WATER, edit('scheme = "two_set"', 'scheme = "collocated"')),
                                              "simulation.scheme"),
    "unknown section": (append("\n[solver]\ntolerance = 1\n"), "solver"),
    "unknown simulation key": (edit("end_time =", "courrant = 0.5\nend_time ="), "simulation.courrant"),
    "string dx": (edit("dx = 0.1", 'dx = "abc"'), "simulation.dx"),
    "boolean dx": (edit("dx = 0.1", "dx = true"), "simulation.dx"),
    "missing material": (edit('material = "soil"', 'material = "clay"'), "bodies.column.material"),
    "newline in a material name": (edit('material = "soil"', 'material = "so\\nil"'), "bodies.column.material"),
    "unknown material model": (edit('model = "elastic"', 'model = "mohr_coulomb"'), "materials.soil.model"),
    "zero E": (edit("youngs_modulus = 1e7", "youngs_modulus = 0"), "materials.soil.youngs_modulus"),
    "negative E": (edit("youngs_modulus = 1e7", "youngs_modulus = -1e7"), "materials.soil.youngs_modulus"),
    "nu = 0.5": (edit("poisson_ratio = 0.3", "poisson_ratio = 0.5"), "materials.soil.poisson_ratio"),
    "nu = -1.2": (edit("poisson_ratio = 0.3", "poisson_ratio = -1.2"), "materials.soil.poisson_ratio"),
    "zero density": (edit("density = 2000", "density = 0"), "materials.soil.density"),
    "empty body": (edit("min = [0, 0]\nmax = [0.5, 2.0]", "min = [0.02, 0.02]\nmax = [0.08, 0.08]"), "bodies.column"),
    "dx far too small": (edit("dx = 0.1", "dx = 1e-11"), "bodies.column"),
    "smoothing ratio 1.0": (edit("smoothing_ratio = 1.3", "smoothing_ratio = 1.0"), "simulation.smoothing_ratio"),
    "smoothing ratio 3.0": (edit("smoothing_ratio = 1.3", "smoothing_ratio = 3.0"), "simulation.smoothing_ratio"),
    "unknown kernel": (edit('kernel = "cubic_spline"', 'kernel = "gaussian"'), "simulation.kernel"),
    "unknown scheme": (edit('scheme = "two_set"', 'scheme = "three_set"'), "simulation.scheme"),
    "bad boundary kind": (edit('kind = "slip"', 'kind = "sticky"'), "boundaries.left.kind"),
    "axis not in dim": (edit('axis = "x"', 'axis = "z"'), "boundaries.left.axis"),
    "decreasing table times": (edit("times = [0.0, 0.1, 0.2]", "times = [0.0, 0.2, 0.1]"),
                               "loads.top.time_function.times[2]"),
    "unknown probe field": (edit('field = "stress_yy"', 'field = "strain_yy"'), "probes.middle.field"),
    "reaction on unknown boundary": (edit('boundary = "base"', 'boundary = "bottom"'), "probes.base_force.boundary"),
    "duplicate body names": (append(SECOND_BODY), "bodies.column.name"),
    "viscoplastic without the effect": (VISCOPLASTIC, "materials.soil.model"),
    "plasticity with the collocated scheme": (chain(PLASTICITY, edit('scheme = "two_set"', 'scheme = "collocated"')),
                                              "simulation.scheme"),
    "unknown yield function": (chain(PLASTICITY, VISCOPLASTIC, material_key('yield_function = "tresca"')),
                               "materials.soil.yield_function"),
    "friction angle 90": (chain(PLASTICITY, VISCOPLASTIC, material_key('yield_function = "mohr_coulomb"\n'
                                                                       "friction_angle = 90")),
                          "materials.soil.friction_angle"),
    "negative friction angle": (chain(PLASTICITY, VISCOPLASTIC, material_key("friction_angle = -5")),
                                "materials.soil.friction_angle"),
    "negative cohesion": (chain(PLASTICITY, VISCOPLASTIC, edit("cohesion = 1e4", "cohesion = -1e4")),
                          "materials.soil.cohesion"),
    "von Mises without cohesion": (chain(PLASTICITY, VISCOPLASTIC, edit("cohesion = 1e4", "cohesion = 0")),
                                   "materials.soil.cohesion"),
    "zero fluidity": (chain(PLASTICITY, VISCOPLASTIC, material_key("fluidity = 0")), "materials.soil.fluidity"),
    "negative fluidity": (chain(PLASTICITY, VISCOPLASTIC, material_key("fluidity = -1")), "materials.soil.fluidity"),
    "zero reference stress": (chain(PLASTICITY, VISCOPLASTIC, material_key("reference_stress = 0")),
                              "materials.soil.reference_stress"),
    "rate exponent below 1": (chain(PLASTICITY, VISCOPLASTIC, material_key("rate_exponent = 0.5")),
                              "materials.soil.rate_exponent"),
    "dilatancy above friction": (chain(PLASTICITY, VISCOPLASTIC, material_key('yield_function = "drucker_prager"\n'
                                                                              "friction_angle = 20\n"
                                                                              "dilatancy_angle = 25")),
                                 "materials.soil.dilatancy_angle"),
    "two yield functions in one scene": (chain(PLASTICITY, VISCOPLASTIC,
                                               append('\n[materials.rock]\nmodel = "viscoplastic"\ncohesion = 1e5\n'
                                                      'yield_function = "mohr_coulomb"\n')),
                                         "materials.rock.yield_function"),
    "residual above cohesion": (chain(PLASTICITY, VISCOPLASTIC, material_key("residual_cohesion = 2e4")),
                                "materials.soil.residual_cohesion"),
    "plastic strain output without plasticity": (
        edit('fields = ["velocity", "stress"]', 'fields = ["velocity", "plastic_strain"]'), "output.fields[1]"),
    "plastic strain probe without plasticity": (edit('field = "stress_yy"', 'field = "plastic_strain"'),
                                                "probes.middle.field"),
    "porosity 0": (material_key("porosity = 0"), "materials.soil.porosity"),
    "porosity 1.2": (material_key("porosity = 1.2"), "materials.soil.porosity"),
    "negative conductivity": (material_key("hydraulic_conductivity = -1e-5"), "materials.soil.hydraulic_conductivity"),
    "conductivity in cm/s": (material_key("hydraulic_conductivity = 5"), "materials.soil.hydraulic_conductivity"),
    "water density in g/cm3": (material_key("water_density = 1"), "materials.soil.water_density"),
    "E in MPa": (edit("youngs_modulus = 1e7", "youngs_modulus = 30"), "materials.soil.youngs_modulus"),
    "water modulus in MPa": (material_key("water_bulk_modulus = 2.2"), "materials.soil.water_bulk_modulus"),
    "infinite E": (edit("youngs_modulus = 1e7", "youngs_modulus = inf"), "materials.soil.youngs_modulus"),
    "negative k0": (material_key("k0 = -0.5"), "materials.soil.k0"),
    "grain density and density": (material_key("grain_density = 2650"), "materials.soil.grain_density"),
    "unknown drainage kind": (chain(PORE_WATER, base_drainage('{ kind = "porous" }')), "boundaries.base.drainage.kind"),
    "unknown drainage key": (chain(PORE_WATER, base_drainage('{ kind = "drained", presure = 0 }')),
                             "boundaries.base.drainage.presure"),
    "infinite drained pressure": (chain(PORE_WATER, base_drainage('{ kind = "drained", pore_pressure = inf }')),
                                  "boundaries.base.drainage.pore_pressure"),
    "drainage extent inside out": (chain(PORE_WATER, base_drainage('{ kind = "drained", extent = { min = [1, 0], '
                                                                   'max = [0, 0] } }')),
                                   "boundaries.base.drainage.extent.max"),
    "drainage without pore water": (base_drainage('{ kind = "drained" }'), "boundaries.base.drainage.kind"),
    "load drainage without pore water": (
        edit("traction = [0, -1e4]", 'traction = [0, -1e4]\ndrainage = { kind = "inflow" }'),
        "loads.top.drainage.kind"),
    "pore pressure without pore water": (edit('shape = "box"', 'shape = "box"\npore_pressure = 1e3'),
                                         "bodies.column.pore_pressure"),
    "water can neither drain nor compress": (chain(PORE_WATER, material_key("water_bulk_modulus = inf"),
                                                   append('\n[pressure]\nfree_surface = "impermeable"\n')),
                                             "effects.pore_water"),
    "unknown pressure solver": (append('\n[pressure]\nsolver = "gmres"\n'), "pressure.solver"),
    "pressure tolerance 0": (append("\n[pressure]\ntolerance = 0\n"), "pressure.tolerance"),
    "pressure max_iterations 0": (append("\n[pressure]\nmax_iterations = 0\n"), "pressure.max_iterations"),
    "unknown pressure key": (append("\n[pressure]\ntolerence = 1e-6\n"), "pressure.tolerence"),
    "pore pressure output without pore water": (
        edit('fields = ["velocity", "stress"]', 'fields = ["velocity", "pore_pressure"]'), "output.fields[1]"),
    "pore pressure probe without pore water": (edit('field = "stress_yy"', 'field = "pore_pressure"'),
                                               "probes.middle.field"),
    "TOML syntax error": (edit("dx = 0.1", "dx = = 0.1"), ""),
    "polygon in 3D": (chain(edit("dim = 2", "dim = 3"), edit("max = [0.5, 2.0]", "max = [0.5, 2.0, 0.5]"),
                            append(TRIANGLE_IN_3D)), "bodies.wedge.shape"),
    "string large_deformation": (edit("end_time = 0.5", 'end_time = 0.5\nlarge_deformation = "yes"'),
                                 "simulation.large_deformation"),
    "unknown virtual_points": (edit("end_time = 0.5", 'end_time = 0.5\nvirtual_points = "remeshed"'),
                               "simulation.virtual_points"),
    "unknown particle_velocity": (edit("end_time = 0.5", 'end_time = 0.5\nlarge_deformation = true\n'
                                                          'particle_velocity = "mean"'),
                                  "simulation.particle_velocity"),
    "negative particle_shifting": (edit("end_time = 0.5", "end_time = 0.5\nlarge_deformation = true\n"
                                                           "particle_shifting = -1"), "simulation.particle_shifting"),
    "velocity_filter above 0.5": (edit("end_time = 0.5", "end_time = 0.5\nvelocity_filter = 0.6"),
                                  "simulation.velocity_filter"),
    "velocity filter with the collocated scheme": (edit('scheme = "two_set"', 'scheme = "collocated"\n'
                                                                          'velocity_filter = 0.02'),
                                                   "simulation.velocity_filter"),
    "unknown virtual_density": (edit("end_time = 0.5", 'end_time = 0.5\nvirtual_density = "summed"'),
                                "simulation.virtual_density"),
    "virtual density with the collocated scheme": (edit('scheme = "two_set"', 'scheme = "collocated"\n'
                                                                          'virtual_density = "real_motion"'),
                                                   "simulation.virtual_density"),
    "stress_filter above 0.5": (edit("end_time = 0.5", "end_time = 0.5\nstress_filter = 0.8"),
                                "simulation.stress_filter"),
    "stress filter with the collocated scheme": (edit('scheme = "two_set"', 'scheme = "collocated"\n'
                                                                        'stress_filter = 0.01'),
                                                 "simulation.stress_filter"),
    "particle shifting without large deformation": (edit("end_time = 0.5", "end_time = 0.5\nparticle_shifting = 5"),
                                                    "simulation"),
    "floor friction angle 90": (chain(edit("end_time = 0.5", "end_time = 0.5\nlarge_deformation = true"),
                                      edit('kind = "slip"', 'kind = "slip"\nfriction_angle = 90')),
                                "boundaries.left.friction_angle"),
    "friction on a fixed wall": (chain(edit("end_time = 0.5", "end_time = 0.5\nlarge_deformation = true"),
                                       edit('kind = "fixed"', 'kind = "fixed"\nfriction_angle = 30')),
                                 "boundaries.base.friction_angle"),
    "force load without region": (append(RIGID.format(kind="force", extra="force = [0, -1000]")), "loads.cap.region"),
    "unknown contact": (append(RIGID.format(kind="velocity", extra='velocity = [0, -0.1]\ncontact = "sticky"\n'
                                                                   "region = { min = [0, 1.9] }")),
                        "loads.cap.contact"),
    "smooth contact without a drive direction": (append(RIGID.format(kind="force", extra='contact = "smooth"\n'
                                                                     "region = { min = [0, 1.9] }")),
                                                 "loads.cap.contact"),
    "reaction probe naming nothing": (append('\n[[probes]]\nname = "r"\nkind = "reaction"\nfield = "y"\n'
                                             'boundary = "cap"\n'), "probes.r.boundary"),
}


def test_base_scene_is_valid():
    scene = parse_scene(BASE)
    assert scene.name == "column"
    assert scene.simulation.gravity == (0.0, -9.81, 0.0)
    assert scene.materials["soil"].name == "soil"
    assert scene.bodies[0].max == (0.5, 2.0, 0.0)
    assert isinstance(scene.materials["soil"].density, float)
    assert scene.loads[0].time_function(0.05) == pytest.approx(0.5)
    assert scene.source_text == BASE


@pytest.mark.parametrize("case", list(BAD_CASES), ids=list(BAD_CASES))
def test_bad_scene_names_key(case):
    make, key = BAD_CASES[case]
    with pytest.raises(SceneError) as info:
        parse_scene(make(BASE))
    assert info.value.key == key
    assert "\n" not in str(info.value)


def test_messages_say_what_is_accepted():
    with pytest.raises(SceneError, match=r"must be in \(-1, 0\.5\), got 0\.6"):
        parse_scene(BASE.replace("poisson_ratio = 0.3", "poisson_ratio = 0.6"))
    with pytest.raises(SceneError, match=r"unknown key; accepted: .*courant, dim, dx"):
        parse_scene(BASE.replace("end_time =", "courrant = 0.5\nend_time ="))
    with pytest.raises(SceneError, match=r'expected a number, got "abc"'):
        parse_scene(BASE.replace("dx = 0.1", 'dx = "abc"'))
    with pytest.raises(SceneError, match=r'defined materials: "soil"'):
        parse_scene(BASE.replace('material = "soil"', 'material = "clay"'))
    with pytest.raises(SceneError, match=r"TOML syntax error: .*line 6"):
        parse_scene(BASE.replace("dx = 0.1", "dx = = 0.1"))
    with pytest.raises(SceneError, match=r"must be >= 1000 Pa: moduli are in Pa, not kPa or MPa .*got 30\.0$"):
        parse_scene(BASE.replace("youngs_modulus = 1e7", "youngs_modulus = 30"))
    with pytest.raises(SceneError, match=r"must be in \[500, 2000\] kg/m³ .*got 1\.0$"):
        parse_scene(BASE.replace("poisson_ratio = 0.3", "poisson_ratio = 0.3\nwater_density = 1"))
    with pytest.raises(SceneError, match=r"must be <= 1 m/s: k_h is in m/s"):
        parse_scene(BASE.replace("poisson_ratio = 0.3", "poisson_ratio = 0.3\nhydraulic_conductivity = 5"))
    with pytest.raises(SceneError, match=r"^materials\.soil\.grain_density: give either density \(the mixture\) or "
                       r"grain_density, not both$"):
        parse_scene(BASE.replace("poisson_ratio = 0.3", "poisson_ratio = 0.3\ngrain_density = 2650"))
    with pytest.raises(SceneError, match=r"^boundaries\.base\.drainage\.kind: needs effects\.pore_water = true$"):
        parse_scene(BASE.replace('kind = "fixed"', 'kind = "fixed"\ndrainage = { kind = "drained" }'))
    with pytest.raises(SceneError, match=r'must be one of "impermeable", "drained", "inflow", got "porous"'):
        parse_scene(BASE.replace('kind = "fixed"', 'kind = "fixed"\ndrainage = { kind = "porous" }'))
    with pytest.raises(SceneError, match=r"^pressure\.solver: must be one of \"cg\", \"jacobi\", got \"gmres\"$"):
        parse_scene(BASE + '\n[pressure]\nsolver = "gmres"\n')
    with pytest.raises(SceneError, match=r"^pressure\.tolerance: must be in \(0, 1\), got 0\.0$"):
        parse_scene(BASE + "\n[pressure]\ntolerance = 0\n")
    with pytest.raises(SceneError, match=r'^output\.fields\[1\]: "pore_pressure" needs effects\.pore_water = true$'):
        parse_scene(BASE.replace('fields = ["velocity", "stress"]', 'fields = ["velocity", "pore_pressure"]'))
    plastic = BASE.replace("pore_water = false", "plasticity = true").replace(
        'model = "elastic"', 'model = "viscoplastic"\ncohesion = 1e4\nyield_function = "mohr_coulomb"')
    with pytest.raises(SceneError, match=r"^materials\.soil\.friction_angle: must be in \[0, 90\), got 90\.0$"):
        parse_scene(plastic.replace("poisson_ratio = 0.3", "poisson_ratio = 0.3\nfriction_angle = 90"))
    with pytest.raises(SceneError, match=r'^materials\.soil\.yield_function: must be one of "von_mises", '
                       r'"drucker_prager", "mohr_coulomb", got "cam_clay"$'):
        parse_scene(plastic.replace('"mohr_coulomb"', '"cam_clay"'))
    with pytest.raises(SceneError, match=r"^materials\.soil\.fluidity: must be > 0, got 0\.0$"):
        parse_scene(plastic.replace("poisson_ratio = 0.3", "poisson_ratio = 0.3\nfluidity = 0"))
    with pytest.raises(SceneError, match=r"unknown section; accepted: .*output, phases, pressure, probes"):
        parse_scene(BASE + "\n[solver]\ntolerance = 1\n")
    with pytest.raises(SceneError, match=r"empty body: no lattice point of spacing dx = 0.1 lies inside it"):
        parse_scene(BASE.replace("max = [0.5, 2.0]", "max = [0.05, 2.0]").replace("min = [0, 0]", "min = [0.01, 0]"))


def test_load_scene_names_scene_after_file(tmp_path):
    path = tmp_path / "my_column.toml"
    path.write_text(BASE.replace('name = "column"\n', ""))
    scene = load_scene(path)
    assert scene.name == "my_column"
    assert scene.source_text == path.read_text()


def test_python_built_scene_is_validated():
    scene = Scene(materials={"soil": Material(name="soil")}, bodies=[Body(material="soil")])
    assert scene.validate() is scene
    scene.simulation = Simulation(dx="abc")
    with pytest.raises(SceneError) as info:
        scene.validate()
    assert info.value.key == "simulation.dx"


def test_fill_box_2d():
    box = Body(min=(0, 0, 0), max=(1, 2, 0))
    points = fill_body(box, 0.5, 2)
    assert points.shape == (15, 3)
    assert count_lattice_points(box, 0.5, 2) == 15
    assert len(fill_cells(box, 0.5, 2)) == 8
    np.testing.assert_array_equal(points[:, 2], 0.0)
    order = np.lexsort((points[:, 0], points[:, 1], points[:, 2]))
    np.testing.assert_array_equal(order, np.arange(len(points)))


def test_fill_circle():
    disc = Body(shape="circle", center=(0, 0, 0), radius=1.0)
    assert len(fill_body(disc, 0.5, 2)) == 13  # integer points with i² + j² <= 4
    assert len(fill_cells(disc, 0.5, 2)) == 12
    assert len(fill_body(disc, 0.5, 3)) == 33
    assert count_lattice_points(disc, 0.5, 3) == 33


def test_fill_triangle():
    triangle = Body(shape="polygon", vertices=[(0, 0), (1, 0), (0, 1)])
    points = fill_body(triangle, 0.5, 2)
    assert {tuple(p[:2]) for p in points} == {(0, 0), (0.5, 0), (1, 0), (0, 0.5), (0.5, 0.5), (0, 1)}
    assert len(fill_cells(triangle, 0.5, 2)) == 3


def test_fill_dim_1_uses_y():
    column = Body(min=(5, 0, 7), max=(6, 1, 8))
    points = fill_body(column, 0.25, 1)
    np.testing.assert_array_equal(points[:, 1], [0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(points[:, [0, 2]], 0.0)
    np.testing.assert_array_equal(fill_cells(column, 0.25, 1)[:, 1], [0.125, 0.375, 0.625, 0.875])


def test_documented_example_is_valid():
    doc = (Path(__file__).parents[1] / "docs" / "scenes.md").read_text()
    example = next(block for block in doc.split("```toml\n")[1:] if "[simulation]" in block)
    scene = parse_scene(example.split("```")[0])
    assert scene.name == "confined_column"
    assert [b.kind for b in scene.boundaries] == ["fixed", "slip", "slip"]
    assert scene.loads[0].traction == (0.0, -10e3, 0.0)
    assert len(fill_body(scene.bodies[0], scene.simulation.dx, 2)) == 11 * 41


def test_documented_terzaghi_example_is_valid():
    doc = (Path(__file__).parents[1] / "docs" / "scenes.md").read_text()
    example = next(block for block in doc.split("```toml\n")[1:] if 'name = "terzaghi"' in block)
    scene = parse_scene(example.split("```")[0])
    soil = scene.materials["soil"]
    assert scene.effects.pore_water and scene.simulation.dim == 1
    assert soil.density == pytest.approx(1700.0, rel=1e-12)
    assert soil.biot_modulus == pytest.approx(1e8 / 0.3, rel=1e-12)  # 333.3 MPa
    assert soil.oedometric_modulus == pytest.approx(1e8 / 3, rel=1e-12)  # 33.33 MPa
    p0 = 5e3 * soil.biot_modulus / (soil.biot_modulus + soil.oedometric_modulus)
    body = scene.bodies[0]
    assert body.pore_pressure == pytest.approx(p0, rel=1e-12)
    assert body.stress[1] == pytest.approx(-(5e3 - p0), rel=1e-12)
    assert body.stress[0] == body.stress[2] == pytest.approx(0.25 * body.stress[1], rel=1e-12)
    assert scene.boundaries[0].drainage.kind == "impermeable"
    assert (scene.loads[0].drainage.kind, scene.loads[0].drainage.pore_pressure) == ("drained", 0.0)
    assert len(fill_body(body, scene.simulation.dx, 1)) == 101


SECOND_BODY = '\n[[bodies]]\nname = "{name}"\nmaterial = "soil"\nmin = [{x0}, {y0}]\nmax = [{x1}, {y1}]\n'
REACH_CASES = {
    "traction face with no particle": (edit("position = 2.0\nside = \"max\"\ntraction", "position = 3.0\nside = "
                                            "\"max\"\ntraction"), "loads.top.position"),
    "load extent missing every particle": (edit("traction = [0, -1e4]", "traction = [0, -1e4]\nextent = { min = [5, 0],"
                                                " max = [6, 3] }"), "loads.top.extent"),
    "point probe far from every particle": (edit("point = [0.25, 1.0]", "point = [50, 50]"), "probes.middle.point"),
    "region_mean over an empty region": (append('\n[[probes]]\nname = "mean"\nkind = "region_mean"\nfield = '
                                                '"stress_yy"\nregion = { min = [5, 5], max = [6, 6] }\n'),
                                         "probes.mean.region"),
    "body below the base": (edit("min = [0, 0]\nmax = [0.5, 2.0]", "min = [0, -3]\nmax = [0.5, -1]"), "bodies.column"),
    "base's side reversed": (edit('kind = "fixed"\naxis = "y"\nposition = 0.0\nside = "min"',
                                  'kind = "fixed"\naxis = "y"\nposition = 0.0\nside = "max"'), "bodies.column"),
    "overlapping bodies": (append(SECOND_BODY.format(name="upper", x0=0, y0=1.0, x1=0.5, y1=2.0)), "bodies.upper"),
    "body thinner than one cell": (edit("dx = 0.1", "dx = 1.0"), "bodies.column"),
    "rigid region with no particle": (append(RIGID.format(kind="velocity", extra="velocity = [0, -0.1]\nregion = { "
                                                          "min = [5, 5], max = [6, 6] }")), "loads.cap.region"),
}


@pytest.mark.parametrize("case", list(REACH_CASES), ids=list(REACH_CASES))
def test_a_scene_that_would_do_nothing_is_refused_when_built(case):
    """Loads, extents, probes and regions that reach no particle, bodies beyond their planes and
    overlapping bodies: the scene is valid as text, its lattice shows the problem."""
    from warpsph.builder import build

    make, key = REACH_CASES[case]
    scene = parse_scene(make(BASE))
    with pytest.raises(SceneError) as info:
        build(scene, device="cpu")
    assert info.value.key == key
    assert "\n" not in str(info.value)


def test_bodies_sharing_a_face_build():
    """Touching bodies share their boundary row (it goes to the body listed first): not an overlap."""
    from warpsph.builder import build

    text = edit("max = [0.5, 2.0]", "max = [0.5, 1.0]")(BASE) + SECOND_BODY.format(name="upper", x0=0, y0=1.0, x1=0.5,
                                                                                    y1=2.0)  # fmt: skip
    model, _ = build(parse_scene(text), device="cpu")
    assert model.particle_count == len(fill_body(parse_scene(BASE).bodies[0], 0.1, 2))


def test_an_embedded_body_takes_what_it_shares():
    """A weaker seed listed first with ``embedded = true`` inside the column: it owns its points."""
    from warpsph.builder import build

    seed = SECOND_BODY.format(name="seed", x0=0.1, y0=0.8, x1=0.4, y1=1.2) + "embedded = true\n"
    text = BASE.replace("[[bodies]]", seed.replace("[[bodies]]", "[[bodies]]", 1) + "\n[[bodies]]", 1)
    scene = parse_scene(text)
    assert [b.name for b in scene.bodies] == ["seed", "column"] and scene.bodies[0].embedded
    model, _ = build(scene, device="cpu")
    assert model.particle_count == len(fill_body(scene.bodies[1], 0.1, 2))


@pytest.mark.parametrize("line, key", [("youngs_modulus = 20000", "youngs_modulus"), ("density = 1.8", "density")])
def test_implausible_values_warn_with_the_unit(line, key):
    old = "youngs_modulus = 1e7" if key == "youngs_modulus" else "density = 2000"
    with pytest.warns(SceneWarning, match=f"materials.soil.{key} = .*(not kPa|not t/m³)"):
        parse_scene(BASE.replace(old, line))


def test_an_angle_in_radians_warns():
    """friction_angle = 0.4887 (28° in radians by mistake) passes the range check but warns, naming the
    key and the degrees it would be; 28° does not."""
    plastic = BASE.replace("pore_water = false", "pore_water = false\nplasticity = true").replace(
        'model = "elastic"', 'model = "viscoplastic"\ncohesion = 1000\nfriction_angle = 0.4887')  # fmt: skip
    with pytest.warns(SceneWarning, match=r"materials.soil.friction_angle = 0.4887° is at most 1.57°, like an angle "
                                          r"in radians \(28° if it is one\): angles are in degrees"):
        parse_scene(plastic)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_scene(plastic.replace("friction_angle = 0.4887", "friction_angle = 28"))


def test_small_cohesion_warns_and_courant_above_1_is_refused():
    plastic = BASE.replace("pore_water = false", "pore_water = false\nplasticity = true").replace(
        'model = "elastic"', 'model = "viscoplastic"\ncohesion = 10\nfriction_angle = 30')  # fmt: skip
    with pytest.warns(SceneWarning, match=r"materials.soil.cohesion = 10.0 Pa is below 100 Pa \(Pa, not kPa\)"):
        parse_scene(plastic)
    with pytest.raises(SceneError, match=r"simulation.courant: must be in \(0, 1.5\] \(the two_set rk4 step's "
                       r"energy grows at 1.7 on the wave column; docs/accuracy.md, \*Stability limit\*\), got 2.0$"):
        parse_scene(BASE.replace('scheme = "two_set"', 'scheme = "two_set"\ncourant = 2'))
    with pytest.raises(SceneError, match=r"simulation.courant: must be in \(0, 0.5\] \(the collocated rk2 step's"):
        parse_scene(BASE.replace('scheme = "two_set"', 'scheme = "collocated"\nintegrator = "rk2"\ncourant = 0.6'))


@pytest.mark.parametrize("data, message", [
    (b"", "the file is empty; a scene needs at least [materials.<name>] and [[bodies]] (docs/scenes.md)"),
    (b'name = "a"\nname = "b"\n', "TOML syntax error: the key 'name' is given twice in one table (at line 2; first "
                                 "at line 1)"),
    (b'name = "caf\xe9"\n', "the file is not UTF-8 text: byte 0xe9 at line 1, column 12 (save it as UTF-8)"),
])  # fmt: skip
def test_scene_files_that_cannot_be_read(tmp_path, data, message):
    path = tmp_path / "scene.toml"
    path.write_bytes(data)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value) == message


def test_a_byte_order_mark_is_dropped(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_bytes(b"\xef\xbb\xbf" + BASE.encode())
    assert load_scene(path).name == "column"
