"""The output quantity kinds, one module each (see :mod:`fenics_plast.quantities.registry` for what a
kind declares). A new quantity is a new module here (plus its test); nothing else is edited."""
