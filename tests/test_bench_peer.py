"""The side-by-side benchmark against PySPH: both sides run the same block, warpsph's side runs in a
process of its own and reports what the comparison reads; the PySPH side runs where PySPH is
installed (never in CI, where the comparison itself is skipped)."""

import json
import math
import subprocess
import sys

import pytest

from warpsph.bench import peer as bench_peer, peer_pysph, throughput as bench


def test_the_peer_block_is_warpsph_s_block():
    """Same lattice, spacing, smoothing length and material on both sides."""
    from warpsph.builder import build

    for n, dim in ((16384, 2), (4096, 3), (1000, 2)):
        shape = peer_pysph.block_shape(n, dim)
        assert shape == bench.block_shape(n, dim)
        coords = peer_pysph.lattice(shape, range(shape[1]))
        model, _ = build(bench.block_scene(n, dim), device="cpu")
        assert len(coords[0]) == math.prod(shape) == model.particle_count
    scene = bench.block_scene(1024)
    soil = scene.materials["soil"]
    assert peer_pysph.DX == scene.simulation.dx and peer_pysph.SMOOTHING_RATIO == scene.simulation.smoothing_ratio
    assert (peer_pysph.DENSITY, peer_pysph.YOUNGS_MODULUS, peer_pysph.POISSON_RATIO) == (
        soil.density, soil.youngs_modulus, soil.poisson_ratio)


def test_several_dimensions_need_the_peer(capsys):
    with pytest.raises(SystemExit) as stop:
        bench.parse_args(["--dim", "2", "3"])
    assert stop.value.code == 2 and "--dim takes one dimension unless --peer is given" in capsys.readouterr().err
    assert bench.parse_args(["--peer", "pysph", "--dim", "2", "3"]).dim == [2, 3]


def test_a_python_without_pysph_is_refused():
    if bench_peer.has_pysph(sys.executable):
        pytest.skip("this Python has PySPH")
    with pytest.raises(SystemExit, match="cannot import pysph"):
        bench_peer.peer_python(sys.executable)


def test_warpsph_side_reports_what_the_comparison_reads():
    ours = bench_peer.run_warpsph(2, 64, 2, 1)
    assert ours["particles"] == 64 and ours["steps"] == 2
    for key in ("particle_steps_per_second", "neighbour_interactions_per_second", "max_rss_bytes",
                "memory_bytes_per_particle"):  # fmt: skip
        assert ours[key] > 0, key


def _peer_python():
    for python in (sys.executable, str(bench_peer.PEER_ENV / "bin" / "python")):
        try:
            if bench_peer.has_pysph(python):
                return python
        except OSError:
            continue
    return None


@pytest.mark.skipif(_peer_python() is None, reason="PySPH is not installed (python -m warpsph.bench --peer pysph "
                                                    "installs it on demand)")  # fmt: skip
def test_side_by_side_with_pysph(tmp_path):
    out = tmp_path / "peer.json"
    assert bench.main(["--peer", "pysph", "--dim", "2", "--sizes", "1024", "--threads", "1", "--rounds", "1",
                       "--steps", "5", "--peer-python", _peer_python(), "--json", str(out)]) == 0  # fmt: skip
    (row,) = json.loads(out.read_text())["rows"]
    assert row["pysph"]["particles"] == row["warpsph"]["particles"] == 1024
    assert all(v > 0 for v in row["ratio"].values())
    assert subprocess.run([_peer_python(), str(bench_peer.PEER_SCRIPT), "--help"], capture_output=True).returncode == 0
