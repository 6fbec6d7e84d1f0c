"""Finite-element layer: structured Q4 meshes and vectorised 2D elasticity kernels."""
