"""Concrete coordinate-free models of the papers, their controllers and exports.

Modules: :mod:`models.pendulum3d` (the 3D pendulum, its reduced models and special
cases), :mod:`models.spherical` (the spherical pendulum of paper 002),
:mod:`models.chain_cart` (the n-link chain pendulum on a cart of paper 003),
:mod:`models.controllers` (the papers' feedback laws; it re-exports the cart law of
:mod:`models.cart_feedback` and the Lyapunov functions of :mod:`models.lyapunov_functions`)
and :mod:`workbench.app.catalogue` (the controllers exportable to C, by name).
"""
