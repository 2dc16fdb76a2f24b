"""Heat conduction coupled to the deformation (issue 37): the temperature as a nodal field on the
body's mesh, solved after each converged mechanical increment (a staggered, isothermal split).

* :mod:`fenics_plast.thermal.boundaries`: the registry of thermal boundary types (a scene's
  ``[thermal_boundary.<name>]`` tables): prescribed temperature, heat flux, convection, radiation;
* :mod:`fenics_plast.thermal.heat`: :class:`~fenics_plast.thermal.heat.HeatConduction`, the field,
  its backward-Euler step and its heat balance;
* :mod:`fenics_plast.thermal.plastic_heat`: the heat the plastic work releases at each quadrature
  point (Taylor-Quinney), from the mechanical state;
* :mod:`fenics_plast.thermal.build`: the scene's ``[thermal]`` table turned into the above.

Standard library only at import time (the schema reads the boundary registry).
"""
