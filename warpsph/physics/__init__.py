"""Constitutive laws and source terms as Warp functions."""
