"""Scene layer of the pore_water effect: its keys parse, mixture densities, drainage and [pressure]."""

from __future__ import annotations

import math

import pytest

from warpsph.errors import SceneError
from warpsph.scene import Body, Boundary, Drainage, Effects, Load, Material, PressureSolver, Region, Scene
from warpsph.scene_toml import parse_scene

SATURATED = """
[simulation]
dim = 2
dx = 0.1
gravity = [0, -9.81]

[effects]
pore_water = true

[materials.soil]
youngs_modulus = 3e7
poisson_ratio = 0.2
porosity = 0.4
grain_density = 2650
water_bulk_modulus = inf
hydraulic_conductivity = 1e-4
k0 = 0.5

[[bodies]]
name = "column"
material = "soil"
max = [0.5, 2.0]
pore_pressure = 1e3
geostatic = true

[[boundaries]]
name = "base"
kind = "fixed"
drainage = { kind = "inflow", inflow = 1e-6 }

[[loads]]
name = "top"
position = 2.0
traction = [0, -1e4]
extent = { min = [0, 0], max = [0.2, 2] }
drainage = { kind = "drained", head = 2.5 }

[[probes]]
name = "base_water"
field = "pore_pressure"
point = [0.25, 0]

[pressure]
solver = "jacobi"
tolerance = 1e-6
max_iterations = 200
jacobi_weight = 0.6
on_failure = "stop"
water_table = 2.0
free_surface = "impermeable"

[output]
fields = ["stress", "pore_pressure", "darcy_velocity"]
"""


def test_saturated_scene_parses():
    scene = parse_scene(SATURATED)
    soil = scene.materials["soil"]
    assert soil.density == pytest.approx(0.6 * 2650 + 0.4 * 1000, rel=1e-15)
    assert soil.grain_bulk_modulus == soil.water_bulk_modulus == math.inf
    assert soil.biot_modulus == math.inf and soil.earth_pressure_at_rest == 0.5
    assert soil.permeability == pytest.approx(1e-4 / (1000 * 9.81))
    body = scene.bodies[0]
    assert body.pore_pressure == 1e3 and body.geostatic is True
    assert scene.boundaries[0].drainage == Drainage(kind="inflow", inflow=1e-6)
    assert scene.loads[0].drainage == Drainage(kind="drained", head=2.5)
    assert scene.pressure == PressureSolver("jacobi", 1e-6, 200, 0.6, "stop", 2.0, "impermeable")
    assert scene.probes[0].field == "pore_pressure"


def test_density_without_grain_density_is_the_mixture_as_given():
    scene = parse_scene(SATURATED.replace("grain_density = 2650", "density = 1900"))
    assert scene.materials["soil"].density == 1900.0 and scene.materials["soil"].grain_density is None


def test_pressure_section_types():
    with pytest.raises(SceneError) as info:
        parse_scene(SATURATED.replace("max_iterations = 200", "max_iterations = 200.0"))
    assert info.value.key == "pressure.max_iterations"
    with pytest.raises(SceneError) as info:
        parse_scene(SATURATED.replace("jacobi_weight = 0.6", "jacobi_weight = 1.5"))
    assert info.value.key == "pressure.jacobi_weight"
    with pytest.raises(SceneError) as info:
        parse_scene(SATURATED.replace('on_failure = "stop"', 'on_failure = "ignore"'))
    assert info.value.key == "pressure.on_failure"
    with pytest.raises(SceneError) as info:
        parse_scene(SATURATED.replace("drainage = { kind = \"drained\", head = 2.5 }", "drainage = \"drained\""))
    assert info.value.key == "loads.top.drainage"


def test_water_must_drain_or_compress():
    """Incompressible constituents need a drained face or a drained free surface."""
    closed = SATURATED.replace('kind = "drained", head = 2.5', 'kind = "impermeable"')
    with pytest.raises(SceneError, match=r"^effects\.pore_water: the pore water can neither drain nor compress"):
        parse_scene(closed)
    parse_scene(closed.replace('free_surface = "impermeable"', 'free_surface = "drained"'))
    parse_scene(closed.replace("water_bulk_modulus = inf", "water_bulk_modulus = 2.2e9"))
    parse_scene(SATURATED)  # the drained top


def python_scene(**material) -> Scene:
    return Scene(
        effects=Effects(pore_water=True),
        materials={"soil": Material(name="soil", **material)},
        bodies=[Body(material="soil")],
    )


def test_python_built_mixture_density_is_checked():
    python_scene().validate()
    python_scene(grain_density=2000.0, porosity=0.3, density=1700.0).validate()
    with pytest.raises(SceneError, match=r"^materials\.soil\.density: with grain_density given, must be the mixture "
                       r"density .* = 1700\.0, got 2000\.0$"):
        python_scene(grain_density=2000.0, porosity=0.3).validate()


def test_python_built_drainage_and_pressure_are_checked():
    scene = python_scene()
    scene.loads = [Load(name="piston", kind="velocity", region=Region(), drainage=Drainage(kind="drained"))]
    with pytest.raises(SceneError) as info:
        scene.validate()
    assert info.value.key == "loads.piston.drainage.kind"
    scene.loads = []
    scene.boundaries = [Boundary(name="base", drainage="drained")]
    with pytest.raises(SceneError, match=r"^boundaries\.base\.drainage: expected a Drainage, got str$"):
        scene.validate()
    scene.boundaries = [Boundary(name="base", drainage=Drainage(kind="drained", head=math.nan))]
    with pytest.raises(SceneError) as info:
        scene.validate()
    assert info.value.key == "boundaries.base.drainage.head"
    scene.boundaries = []
    scene.pressure = PressureSolver(water_table=math.inf)
    with pytest.raises(SceneError) as info:
        scene.validate()
    assert info.value.key == "pressure.water_table"
    scene.pressure = {"solver": "cg"}
    with pytest.raises(SceneError, match=r"^pressure: expected a PressureSolver, got dict$"):
        scene.validate()
