"""warpsph: two-set Runge-Kutta Taylor SPH for saturated soils, on NVIDIA Warp."""

__version__ = "0.1.0"
