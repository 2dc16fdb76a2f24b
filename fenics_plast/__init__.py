"""fenics-plast: finite-strain elastoplasticity after Simo-Ortiz and Garcia Garino, Oliver & Botello.

Units everywhere inside the package: mm, N, MPa, s, tonne/mm^3 (a consistent set).
"""
__version__ = "0.1.0"
