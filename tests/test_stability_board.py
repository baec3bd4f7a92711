"""The stability scoreboard (``python -m warpsph.stability``, docs/stability.md, *Scoreboard*): its
command runs the cases asked for under the options given, prints a row per measured quantity and
writes them as JSON; the patch tests see a control that acts on linear motion."""

import json

import pytest

from warpsph.stability import CASES
from warpsph.stability.__main__ import main


def board(tmp_path, capsys, *args):
    out = tmp_path / "board.json"
    code = main(["--only", "patch_affine", "patch_rotation", "--out", str(out), *args])
    return code, json.loads(out.read_text()), capsys.readouterr()


def test_the_patch_tests_hold_at_the_defaults(tmp_path, capsys):
    """No control acts at the defaults: the plate's affine motion and rigid rotation step exactly as
    with every control off."""
    code, written, printed = board(tmp_path, capsys)
    print(printed.out)
    assert code == 0 and [r["case"] for r in written["rows"]] == ["patch_affine", "patch_rotation"]
    assert all(r["holds"] and r["measured"] == 0.0 for r in written["rows"])
    assert "| patch_affine | largest change by the control | 0 | ≤ 1e-10 | yes |" in printed.out


@pytest.mark.parametrize("key, acts_on_rotation", [("artificial_viscosity", False), ("velocity_filter", False),
                                                   ("stress_filter", True)])
def test_the_patch_tests_see_a_control_that_acts_on_linear_motion(tmp_path, capsys, key, acts_on_rotation):
    """Monaghan's viscosity acts on the affine motion's compression, the velocity filter on its
    surfaces (the fitted velocity differs there from the particle's own), neither on a rigid rotation;
    the stress filter acts on both: the rows say so, and the command exits 1."""
    code, written, printed = board(tmp_path, capsys, "--set", f"simulation.{key}=0.1")
    affine, rotation = written["rows"]
    print(printed.out)
    assert code == 1 and written["options"] == {f"simulation.{key}": 0.1}
    assert not affine["holds"] and affine["measured"] > 1e-9
    assert rotation["holds"] is not acts_on_rotation


def test_the_hourglass_control_is_zero_for_linear_motion(tmp_path, capsys):
    """The hourglass control damps only what the real particles' own linear fit does not hold: both
    patch tests hold with it at full strength, to round-off."""
    code, written, printed = board(tmp_path, capsys, "--set", "simulation.hourglass_control=1")
    print(printed.out)
    assert code == 0 and all(r["holds"] and r["measured"] < 1e-14 for r in written["rows"])


@pytest.mark.parametrize("option, message", [
    ("simulation.velocity_filtr=0.1", "simulation.velocity_filtr: unknown key; accepted: artificial_viscosity,"),
    ("simulation.velocity_filter=-1", "simulation.velocity_filter: must be in [0, 0.5], got -1.0"),
    ("materials.soil.density=1", "materials.soil.density: not a key the scoreboard sets; accepted: simulation or "
                                 "pressure.<key>"),
])
def test_a_bad_option_is_one_line_and_exit_2(tmp_path, capsys, option, message):
    assert main(["--only", "patch_affine", "--set", option, "--out", str(tmp_path / "b.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("python -m warpsph.stability: error: " + message)


def test_the_board_lists_the_hard_cases():
    assert list(CASES)[:2] == ["patch_affine", "patch_rotation"]
    assert {"free_plate", "cantilever", "free_bar", "spinning_disc", "block_own_weight"} <= set(CASES)


def test_boards_compare_side_by_side(tmp_path, capsys):
    """``--compare`` prints boards written before side by side, labelled by their options."""
    for name, args in (("defaults", []), ("viscosity", ["--set", "simulation.artificial_viscosity=0.1"])):
        main(["--only", "patch_affine", "--out", str(tmp_path / f"{name}.json"), *args])
    capsys.readouterr()
    assert main(["--compare", str(tmp_path / "defaults.json"), str(tmp_path / "viscosity.json")]) == 0
    lines = capsys.readouterr().out.splitlines()
    print("\n".join(lines))
    assert lines[0] == "| case | quantity | limit | defaults | artificial_viscosity = 0.1 |"
    assert lines[2].startswith("| patch_affine | largest change by the control | ≤ 1e-10 | 0 ✓ (")
    assert main(["--compare", str(tmp_path / "missing.json")]) == 2


def test_force_at_rest_vanishes_in_the_geostatic_state_and_grows_with_the_departure_from_it():
    """The board's force at rest on a block: with the exact geostatic stress (σ_yy = −ρg(H − y),
    σ_xx = σ_zz = K₀σ_yy) no force is left unbalanced (the operators fit that linear field exactly);
    with 1.01 times it, 0.01 of what the unstressed block leaves (the step is linear in the stress at
    rest), which is most of its weight (the fixed base's particles do not fall)."""
    from warpsph.bench.throughput import block_scene
    from warpsph.builder import build
    from warpsph.stability.tools import force_at_rest

    scene = block_scene(400, 2)
    model, state = build(scene, "cpu")
    n = model.particle_count
    mass = model.particle_mass.numpy()[:n]
    weight = float(mass.sum()) * 9.81
    unstressed = force_at_rest(model, state) / weight
    q = state.particle_q.numpy()
    density = float(mass[0]) / scene.simulation.dx**2
    nu = next(iter(scene.materials.values())).poisson_ratio
    stress = state.particle_stress.numpy()
    sigma_yy = -density * 9.81 * (q[:n, 1].max() - q[:, 1])

    def at(factor: float) -> float:
        stress[:, 1, 1] = factor * sigma_yy
        stress[:, 0, 0] = stress[:, 2, 2] = factor * nu / (1.0 - nu) * sigma_yy
        state.particle_stress.assign(stress)
        return force_at_rest(model, state) / weight

    assert 0.9 < unstressed < 0.95 + 1e-12
    assert at(1.0) < 1e-12
    assert at(1.01) == pytest.approx(0.01 * unstressed, rel=1e-6)
