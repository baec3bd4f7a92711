"""Flow phases: groundwater flow through the fixed skeleton against closed forms (docs/scenes.md,
*Groundwater flow*).

- Steady seepage through a rectangular dam on an impermeable base, reservoirs on both faces: the
  discharge is Dupuit's q = k (h₁² − h₂²)/(2L), exact for the discharge of the free-surface problem;
  a sharp retention curve keeps the capillary fringe's share small. A seepage face forms above the
  tailwater.
- A saturated column of compressible water over an impermeable base, its top drained at once
  (rigid skeleton): p/p₀ = Σ 2/M sin(M z/H) exp(−M² T), M = π(2m + 1)/2, T = k Q t/H², z the depth.
- Infiltration toward the water table through a Gardner soil, the rate at the surface raised from
  0.1 to 0.9 K_s after a steady flow (Srivastava & Yeh 1991): the pressure head within 2 % of its
  range at every frame.
- Partially saturated soil: water is conserved (the storage rate balances the discharges).
"""

import math
import subprocess
import sys

import h5py
import numpy as np
import pytest

from warpsph.errors import SceneError
from warpsph.runner import run_scene
from warpsph.scene_toml import parse_scene
from warpsph.verification import gardner_infiltration, terzaghi_pressure

DAM = """
[simulation]
dim = 2
dx = {dx}
gravity = [0, -9.81, 0]

[effects]
pore_water = true

[materials.sand]
density = 2000
youngs_modulus = 1e7
porosity = 0.3
hydraulic_conductivity = 1e-5
water_bulk_modulus = inf
retention = "van_genuchten"
retention_alpha = {alpha}
retention_n = 4.0

[[bodies]]
name = "dam"
material = "sand"
min = [0, 0, 0]
max = [6, 5, 0]

[[boundaries]]
name = "base"
kind = "fixed"
axis = "y"
position = 0
side = "min"

[[reservoirs]]
name = "upstream"
level = 4.0
region = {{ min = [-1, -1, -1], max = [3, 10, 1] }}

[[reservoirs]]
name = "tailwater"
level = 1.0
region = {{ min = [3, -1, -1], max = [7, 10, 1] }}

[output]
fields = ["velocity"]
usd = false
xdmf = false

[[phases]]
name = "seepage"
kind = "flow"
steady = true
max_steps = 100
"""
DUPUIT = 1e-5 * (4.0**2 - 1.0**2) / (2.0 * 6.0)


def series(out, name):
    with h5py.File(out / "results.h5", "r") as f:
        return f["series"][name]["value"][...]


def run_dam(tmp_path, dx, alpha):
    scene = parse_scene(DAM.format(dx=dx, alpha=alpha), name="dam")
    run_scene(scene, tmp_path)
    return {name: float(series(tmp_path, f"discharge_{name}")[-1])
            for name in ("upstream", "tailwater", "seepage", "base")}  # fmt: skip


def test_steady_seepage_through_a_dam_gives_dupuits_discharge(tmp_path):
    q = run_dam(tmp_path, 0.25, 30.0)
    inflow = -q["upstream"]
    assert inflow == pytest.approx(DUPUIT, rel=0.02)
    assert q["tailwater"] + q["seepage"] == pytest.approx(inflow, rel=1e-6)  # what enters leaves
    assert q["seepage"] > 0.1 * inflow  # a seepage face above the tailwater carries part of it
    assert q["base"] == 0.0
    with h5py.File(tmp_path / "results.h5", "r") as f:
        frame = f["frames"][sorted(f["frames"])[-1]]
        x, p, s = frame["position"][...], frame["pore_pressure"][...], frame["saturation"][...]
    face = np.isclose(x[:, 0], 6.0)
    assert np.all(p[face & (x[:, 1] > 1.0)] <= 1e-6)  # above the tailwater the face is at most atmospheric ...
    wet = face & (x[:, 1] > 1.0) & (p > -1.0)
    assert wet.any() and x[wet, 1].max() >= 1.25  # ... and water leaves it above the tailwater
    assert s.min() < 0.1 and s.max() == 1.0  # a dry crest over a saturated core


@pytest.mark.parametrize("dx, alpha", [(0.125, 30.0), (0.0625, 100.0)])
def test_dupuit_discharge_under_refinement(tmp_path, dx, alpha):
    q = run_dam(tmp_path, dx, alpha)
    assert -q["upstream"] == pytest.approx(DUPUIT, rel=0.01)


COLUMN = """
[simulation]
dim = 1
dx = 0.05
gravity = [0, -9.81, 0]

[effects]
pore_water = true

[materials.soil]
density = 2000
youngs_modulus = 1e7
porosity = 0.3
hydraulic_conductivity = 1e-8
water_bulk_modulus = 2.2e6

[[bodies]]
name = "column"
material = "soil"
min = [0, 0]
max = [0, 1]
pore_pressure = 1e4

[[boundaries]]
name = "base"
kind = "fixed"
axis = "y"
position = 0
side = "min"

[[boundaries]]
name = "top"
kind = "free"
axis = "y"
position = 1
side = "max"
drainage = {{ kind = "drained", pore_pressure = 0.0 }}

[output]
fields = []
usd = false
xdmf = false

[[phases]]
name = "drainage"
kind = "flow"
duration = {duration}
frames = 10
"""


def test_transient_flow_follows_the_diffusion_closed_form(tmp_path):
    k = 1e-8 / (1000.0 * 9.81)
    Q = 2.2e6 / 0.3
    c = k * Q
    duration = 1.0 / c  # T = 1
    scene = parse_scene(COLUMN.format(duration=duration), name="column")
    run_scene(scene, tmp_path)
    with h5py.File(tmp_path / "results.h5", "r") as f:
        frames = [f["frames"][key] for key in sorted(f["frames"])]
        errors = {}
        for frame in frames[1:]:
            t = float(frame.attrs["time"])
            y = frame["position"][:, 1]
            excess = frame["pore_pressure"][...] - 1000.0 * 9.81 * (1.0 - y)
            exact = terzaghi_pressure(1.0 - y, 1.0, 1e4, c * t)
            errors[round(c * t, 3)] = float(np.sqrt(np.mean((excess - exact) ** 2))) / 1e4
    assert set(errors) >= {0.1, 0.2, 0.5, 1.0}
    assert max(errors.values()) < 0.02, errors
    steps = len(series(tmp_path, "flow_iterations"))
    assert steps < 1e-3 * duration / scene.time_step  # steps sized by accuracy, not by the wave speed


def test_unsaturated_flow_conserves_water(tmp_path):
    """Water rises into a dry column from a drained base: what enters is what is stored."""
    text = (COLUMN.format(duration=2e7)
            .replace("water_bulk_modulus = 2.2e6", 'water_bulk_modulus = inf\nretention = "van_genuchten"\n'
                     "retention_alpha = 2.0\nretention_n = 2.0\nresidual_saturation = 0.1")
            .replace("pore_pressure = 1e4", "pore_pressure = -1e4")
            .replace('drainage = { kind = "drained", pore_pressure = 0.0 }', "")
            .replace('side = "min"\n', 'side = "min"\ndrainage = { kind = "drained", head = 0.5 }\n', 1))  # fmt: skip
    run_scene(parse_scene(text, name="rise"), tmp_path)
    inflow = -series(tmp_path, "discharge_base")
    stored = series(tmp_path, "storage_rate")
    assert inflow[0] > 0.0
    np.testing.assert_allclose(stored, inflow, rtol=1e-6, atol=1e-9 * inflow[0])


def test_flow_phase_input_errors():
    with pytest.raises(SceneError, match=r"phases.seepage.kind.*pore_water"):
        parse_scene(DAM.format(dx=0.25, alpha=30.0).replace("pore_water = true", "pore_water = false")
                    .replace('retention = "van_genuchten"', ""))  # fmt: skip
    with pytest.raises(SceneError, match=r"materials.sand.retention_n"):
        parse_scene(DAM.format(dx=0.25, alpha=30.0).replace("retention_n = 4.0", "retention_n = 1.0"))
    with pytest.raises(SceneError, match=r"materials.sand.retention_alpha"):
        parse_scene(DAM.format(dx=0.25, alpha=-1.0))
    with pytest.raises(SceneError, match=r"materials.sand.retention\b"):
        parse_scene(DAM.format(dx=0.25, alpha=30.0).replace('"van_genuchten"', '"brooks_corey"'))
    with pytest.raises(SceneError, match=r"reservoirs.upstream.time_function.times"):
        parse_scene(DAM.format(dx=0.25, alpha=30.0).replace(
            "level = 4.0", "level = 4.0\ntime_function = { kind = \"table\", times = [0, 5, 3], values = [0, 1, 1] }"))
    with pytest.raises(SceneError, match=r"phases.seepage.steady"):
        text = DAM.format(dx=0.25, alpha=30.0)
        parse_scene(text[: text.index("[[reservoirs]]")] + text[text.index("[output]"):])


def test_a_reservoir_that_touches_no_surface_is_refused(tmp_path):
    """By the run, and by ``warpsph validate`` before it, with one line naming the key."""
    text = DAM.format(dx=0.25, alpha=30.0).replace("max = [3, 10, 1]", "max = [-0.5, 10, 1]")
    with pytest.raises(SceneError, match=r"reservoirs.upstream.region.*touches no surface"):
        run_scene(parse_scene(text, name="dam"), tmp_path / "run")
    (tmp_path / "dam.toml").write_text('name = "dam"\n' + text)
    result = subprocess.run([sys.executable, "-m", "warpsph", "validate", str(tmp_path / "dam.toml"), "--no-estimate"],
                            capture_output=True, text=True)  # fmt: skip
    assert result.returncode == 2 and "reservoirs.upstream.region: contains no free-surface particle" in result.stderr


def test_a_flow_phase_resumes_bit_identical(tmp_path):
    k = 1e-8 / (1000.0 * 9.81)
    duration = 0.3 / (k * 2.2e6 / 0.3)
    scene = parse_scene(COLUMN.format(duration=duration), name="column")
    run_scene(scene, tmp_path / "whole")
    run_scene(scene, tmp_path / "split", end_time=0.5 * duration)
    run_scene(scene, tmp_path / "split", resume=True)
    finals = []
    for name in ("whole", "split"):
        with h5py.File(tmp_path / name / "results.h5", "r") as f:
            last = f["frames"][sorted(f["frames"])[-1]]
            finals.append((float(last.attrs["time"]), last["pore_pressure"][...]))
    assert finals[0][0] == finals[1][0] == pytest.approx(duration)
    np.testing.assert_array_equal(finals[0][1], finals[1][1])


INFILTRATION = """
[simulation]
dim = 1
dx = 0.02
gravity = [0, -9.81, 0]

[effects]
pore_water = true

[materials.soil]
density = 2000
youngs_modulus = 1e7
porosity = 0.45
hydraulic_conductivity = 1e-5
water_bulk_modulus = inf
retention = "gardner"
retention_alpha = 10.0
residual_saturation = 0.4444444444444444       # θ_r = 0.2, θ_s = 0.45

[[bodies]]
name = "column"
material = "soil"
min = [0, 0]
max = [0, 1]

[[boundaries]]
name = "water_table"
kind = "fixed"
axis = "y"
position = 0
side = "min"
drainage = { kind = "drained", pore_pressure = 0.0 }

[[boundaries]]
name = "surface"
kind = "free"
axis = "y"
position = 1
side = "max"
drainage = { kind = "inflow", inflow = 1e-6 }

[output]
fields = []
usd = false
xdmf = false

[[phases]]
name = "initial"
kind = "flow"
steady = true

[[phases]]
name = "rain"
kind = "flow"
duration = 1e5
frames = 10
changes = { "boundaries.surface.drainage.inflow" = 9e-6 }
"""


def test_infiltration_toward_the_water_table_matches_srivastava_and_yeh(tmp_path):
    run_scene(parse_scene(INFILTRATION, name="infiltration"), tmp_path)
    alpha = 10.0
    head_range = -math.log(0.1) / alpha  # the initial suction head at the surface [m]
    errors = []
    with h5py.File(tmp_path / "results.h5", "r") as f:
        for key in sorted(f["frames"])[1:]:
            frame = f["frames"][key]
            y = frame["position"][:, 1]
            head = frame["pore_pressure"][...] / (1000.0 * 9.81)
            exact = np.log(gardner_infiltration(y, float(frame.attrs["time"]), 1.0, alpha, 0.25, 1e-5, 1e-6,
                                                9e-6)) / alpha  # fmt: skip
            errors.append(float(np.sqrt(np.mean((head - exact) ** 2))) / head_range)
    assert len(errors) == 12  # the steady start, and ten frames of the rain with its first
    assert max(errors) < 0.02, errors
