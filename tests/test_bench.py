"""The throughput benchmark runs end to end and writes a complete JSON record (not a timed test)."""

import json

from warpsph.bench.throughput import block_scene, block_shape, default_steps, main

PER_SIZE = ("particles", "steps", "wall_seconds", "compile_seconds", "particle_steps_per_second",
            "neighbour_pairs_per_step", "neighbour_interactions_per_second", "memory_bytes_per_particle")  # fmt: skip


def test_block_shape_hits_the_ladder():
    assert block_shape(16384, 2) == (128, 128)
    assert block_shape(13824, 3) == (24, 24, 24)
    scene = block_scene(64, dim=3)
    assert [b.kind for b in scene.boundaries] == ["fixed", "slip", "slip", "slip", "slip"]
    assert block_scene(64, effects="saturated").effects.pore_water
    assert block_scene(64, effects="viscoplastic").effects.plasticity
    assert default_steps(1024, 2) == 200 and default_steps(65536, 2) == 31 and default_steps(10**6, 3) == 10


def test_bench_writes_positive_figures(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["--quick", "--scheme", "both", "--effects", "dry", "saturated", "viscoplastic", "--threads", "1", "2",
                 "--json", str(out)]) == 0  # fmt: skip
    record = json.loads(out.read_text())
    machine = record["machine"]
    assert machine["cpu_count"] >= 1 and machine["warp_version"] and machine["device_name"] and machine["platform"]
    results = record["results"]
    cases = [("two_set", "dry"), ("collocated", "dry"), ("two_set", "saturated"), ("two_set", "viscoplastic")]
    assert [(r["scheme"], r["effects"], r["particles"], r["threads"]) for r in results] == [
        (s, e, n, t) for s, e in cases for n in (64, 256) for t in (1, 2)]
    for r in results:
        assert all(r[k] > 0 for k in PER_SIZE), r
        assert r["memory_bytes"]["model"] > 0 and r["memory_bytes"]["states"] > 0
        assert abs(sum(r["stage_share"].values()) - 1.0) < 1e-9 and "neighbours" in r["stage_share"]
        assert (r["virtual_points"] > 0) == (r["scheme"] == "two_set")
        assert ("pressure_projection" in r["stage_share"]) == (r["effects"] == "saturated")
        its = r["solve_iterations_per_step"]
        assert (its is None) == (r["effects"] != "saturated") and (its is None or its >= 1), r
    assert "particle-steps/s" in capsys.readouterr().out


def test_incremental_case_turns_on_the_scenes_incremental_trials():
    from warpsph.bench.phases import case_scene

    scene = case_scene("slope_fos_incremental")
    assert [p.incremental for p in scene.phases if p.kind == "safety"] == [True]
    assert not any(p.incremental for p in case_scene("slope_fos").phases)


def test_phase_costs_report_trials_and_implicit_steps(tmp_path):
    """bench.phases on a coarse vertical cut's safety search and a coarse consolidating column: each phase's
    steps and wall time; the trials and steps per trial of the search; the implicit steps and fixed-stress
    iterations per step of the consolidation."""
    from warpsph.bench.phases import phase_costs
    from warpsph.validation.safety import strength_reduction_phases, undrained_clay
    from test_consolidation import consolidation_scene

    cut = phase_costs(undrained_clay("cut", [(0, 0), (8, 0), (8, 4), (4, 4), (4, 2), (0, 2)], 0.5,
                                     strength_reduction_phases(500, 0.2), 20e3), tmp_path / "cut")  # fmt: skip
    assert [r["kind"] for r in cut] == ["k0", "equilibrium", "safety"]
    safety = cut[-1]
    assert safety["trials"] >= 2 and safety["steps_per_trial"] == safety["steps"] / safety["trials"]
    assert 1.0 <= safety["factor"] <= 3.0
    assert all(r["wall_seconds"] > 0.0 for r in cut)
    (column,) = phase_costs(consolidation_scene(1.0, tv_end=0.05, frames=1), tmp_path / "column")
    assert column["kind"] == "consolidation" and column["implicit_steps"] >= 1 and column["iterations_per_step"] >= 1
