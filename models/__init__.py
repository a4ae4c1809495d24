"""Concrete coordinate-free models of the papers.

Modules: :mod:`models.pendulum3d` (the 3D pendulum, its reduced models and special
cases), :mod:`models.spherical` (the spherical pendulum of paper 002),
:mod:`models.chain_cart` (the n-link chain pendulum on a cart of paper 003).
"""
