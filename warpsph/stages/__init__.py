"""Stages of a time step: each owns its kernels and launches them on a Model and States."""
