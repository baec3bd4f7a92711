"""The pressure-projection benchmark runs end to end and writes a complete JSON record (not a timed test)."""

import json
import math

import pytest

from warpsph.bench.pressure import STAGE, consolidation_coefficient, consolidation_scene, main, parse_args

PER_CASE = ("particles", "steps", "wall_seconds", "seconds_per_step", "particle_steps_per_second",
            "iterations_mean", "iterations_max", "solve_seconds_per_step", "solve_share", "final_residual",
            "memory_bytes_per_particle")  # fmt: skip


def test_scene_is_a_drained_top_consolidation_problem():
    args = parse_args(["--hydraulic-conductivity", "1e-8", "--water-bulk-modulus", "inf"])
    scene = consolidation_scene(64, "jacobi", args)
    soil = scene.materials["soil"]
    assert scene.effects.pore_water and scene.pressure.solver == "jacobi"
    assert soil.hydraulic_conductivity == 1e-8 and math.isinf(soil.water_bulk_modulus) and soil.density == 1700.0
    assert [(b.kind, b.drainage.kind) for b in scene.boundaries] == [("fixed", "impermeable"),
                                                                      ("slip", "impermeable"), ("slip", "impermeable")]
    (load,) = scene.loads
    assert load.drainage.kind == "drained" and load.traction[1] < 0 and load.time_function.kind == "step"
    # c_v = k_h E_oed / γ_w with incompressible water and rigid grains
    assert consolidation_coefficient(scene) == pytest.approx(1e-8 * soil.oedometric_modulus / (1000.0 * 9.81))


def test_bench_pressure_writes_solver_figures(tmp_path, capsys):
    out = tmp_path / "bench_pressure.json"
    assert main(["--sizes", "64", "256", "--steps", "2", "--json", str(out)]) == 0
    record = json.loads(out.read_text())
    assert record["machine"]["cpu_count"] >= 1 and record["machine"]["warp_version"]
    assert record["settings"]["tolerance"] == 1e-8 and record["settings"]["steps"] == 2
    results = record["results"]
    assert [(r["solver"], r["particles"]) for r in results] == [
        ("jacobi", 64), ("cg", 64), ("jacobi", 256), ("cg", 256)]
    for r in results:
        assert all(r[k] > 0 for k in PER_CASE), r
        assert len(r["iterations_per_step"]) == 2 and r["iterations_max"] >= r["iterations_mean"] >= 1
        assert 0 < r["solve_share"] < 1 and STAGE in r["stage_seconds_per_step"]
        assert r["solve_seconds_per_step"] == r["stage_seconds_per_step"][STAGE]
        assert r["missed_tolerance"] == 0 and r["final_residual"] <= r["residual_max"] <= 1e-8
    by = {(r["solver"], r["particles"]): r for r in results}
    assert by["cg", 256]["iterations_mean"] < by["jacobi", 256]["iterations_mean"]
    output = capsys.readouterr().out
    assert "mean it" in output and "solve share %" in output
