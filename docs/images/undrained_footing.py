"""The README's picture: scenes/undrained_footing.toml at the peak of its excess pore pressure and at
its end. Run from the repository root: ``python docs/images/undrained_footing.py`` (about 20 s)."""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import warpsph  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
WATER_GRAVITY = 1000.0 * 9.81
"""ρ_w g [Pa/m]."""
OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "runs" / "undrained_footing_picture"


def main() -> None:
    scene = warpsph.load_scene(ROOT / "scenes" / "undrained_footing.toml")
    scene.output.usd = False
    scene.output.frame_interval = 0.05
    warpsph.run_scene(scene, OUT, overwrite=True)
    results = warpsph.load_results(OUT / "results.h5")
    times, p = results.series("pore_pressure_centre")
    peak = int(np.argmin(np.abs(results.times - times[p.argmax()])))
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.4), constrained_layout=True)
    for ax, index, field, label, cmap in (
            (axes[0], peak, "pore_pressure", "excess pore pressure [kPa]", "viridis"),
            (axes[1], len(results) - 1, "plastic_strain", "equivalent plastic strain [-]", "magma")):
        frame = results.frame(index)
        x = frame["position"]
        values = frame[field]
        if field == "pore_pressure":  # less the hydrostatic pressure below the water table
            values = (values - WATER_GRAVITY * (scene.pressure.water_table - x[:, 1])) / 1e3
        dots = ax.scatter(x[:, 0], x[:, 1], c=values, s=9, cmap=cmap, vmax=None if index == peak else 0.05)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_title(f"t = {results.times[index]:.2f} s")
        fig.colorbar(dots, ax=ax, label=label, shrink=0.8)
    axes[0].set_ylabel("y [m]")
    fig.suptitle("A strip footing loaded in 0.1 s on saturated c′–φ′ soil (scenes/undrained_footing.toml, Δx = 0.25 m)")
    fig.savefig(ROOT / "docs" / "images" / "undrained_footing.png", dpi=110)


if __name__ == "__main__":
    main()
