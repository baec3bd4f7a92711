"""The throughput benchmark runs end to end and writes a complete JSON record (not a timed test)."""

import json

from warpsph.bench import block_scene, block_shape, main

PER_SIZE = ("particles", "steps", "wall_seconds", "compile_seconds", "particle_steps_per_second",
            "neighbour_pairs_per_step", "neighbour_interactions_per_second", "memory_bytes_per_particle")  # fmt: skip


def test_block_shape_hits_the_ladder():
    assert block_shape(16384, 2) == (128, 128)
    assert block_shape(13824, 3) == (24, 24, 24)
    scene = block_scene(64, dim=3)
    assert [b.kind for b in scene.boundaries] == ["fixed", "slip", "slip", "slip", "slip"]


def test_bench_writes_positive_figures(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["--sizes", "64", "256", "--steps", "3", "--scheme", "both", "--json", str(out)]) == 0
    record = json.loads(out.read_text())
    machine = record["machine"]
    assert machine["cpu_count"] >= 1 and machine["warp_version"] and machine["device_name"] and machine["platform"]
    results = record["results"]
    assert [(r["scheme"], r["particles"]) for r in results] == [
        ("two_set", 64), ("two_set", 256), ("collocated", 64), ("collocated", 256)]
    for r in results:
        assert all(r[k] > 0 for k in PER_SIZE), r
        assert r["memory_bytes"]["model"] > 0 and r["memory_bytes"]["states"] > 0
        assert abs(sum(r["stage_share"].values()) - 1.0) < 1e-9 and "neighbours" in r["stage_share"]
        assert (r["virtual_points"] > 0) == (r["scheme"] == "two_set")
    assert "particle-steps/s" in capsys.readouterr().out
