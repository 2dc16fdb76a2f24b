"""The quadrature-point state of the materials, declared once: name, shape, initial value, unit.

>>> [v.name for v in present(material)]          # a Johnson-Cook material
['binv', 'eqps', 'temperature']

Every point of a body stores each variable of :data:`STATE` (the compiled kernels take them all);
:func:`present` gives those a material set has (``when``: a material attribute that must be true,
e.g. ``thermal`` for the temperature of Johnson-Cook materials). What stores, commits, checkpoints
or writes the state iterates over these declarations: the allocation and the commit of
:class:`fenics_plast.quadrature.QuadratureMap`, the solvers' checkpoint state (key = ``name``), the
XDMF fields and final_shape.csv of the runners (``output``), the ``field`` output quantity and the
``shape`` plots' field choices of the schema. The compiled kernels and fused passes still take the
arrays as named arguments (``binv``, ``eqps``, ``temp``): a new variable is also a new argument
there (docs/DESIGN.md, "Where to add").

Shapes: per point, the same in 2-D (plane strain, axisymmetric) and 3-D: the in-plane kinematics
keep the full 3x3 tensors. Standard library only (the schema imports it).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["StateVariable", "STATE", "present", "outputs", "by_output"]


@dataclass(frozen=True)
class StateVariable:
    """One quadrature-point state variable.

    name : attribute of the QuadratureMap (committed values; ``name + "_trial"``: the trial ones) and
        key of the solvers' checkpoint state.
    shape : shape per point (() scalar, (3, 3) tensor); the arrays are (n,) + shape.
    initial : value of a virgin point: "zero", "identity" (3x3), or the name of a material method
        ``f(n) -> (n,) + shape`` (per point, e.g. each point its material's initial temperature).
    description, unit : meaning and unit ("" dimensionless), for field labels and history columns.
    output : name of its cell-mean field (XDMF, final_shape.csv column, ``field`` quantity and
        ``shape`` plot choice), or None when it is not written.
    when : attribute of the material (set) that must be true for the variable to be part of its
        state (committed, checkpointed, written), or None: always.
    """

    name: str
    shape: tuple
    initial: str
    description: str
    unit: str = ""
    output: str | None = None
    when: str | None = None

    def label(self) -> str:
        """Axis label: the description and the unit in brackets (none when dimensionless)."""
        return f"{self.description} [{self.unit}]" if self.unit else self.description


#: every state variable, in the order they are stored, checkpointed and written
STATE = (
    StateVariable("binv", (3, 3), "identity", "inverse elastic left Cauchy-Green tensor b_e^-1"),
    StateVariable("eqps", (), "zero", "equivalent plastic strain", output="eqps"),
    StateVariable("temperature", (), "initial_temperatures", "temperature", unit="K", output="temperature",
                  when="thermal"),
)


def present(material) -> tuple:
    """The variables of :data:`STATE` that ``material`` (a Material or MaterialRegions) has."""
    return tuple(v for v in STATE if v.when is None or bool(getattr(material, v.when, False)))


def outputs(variables=STATE) -> tuple:
    """Output names of the written ones among ``variables``, in order."""
    return tuple(v.output for v in variables if v.output)


def by_output(name: str) -> StateVariable | None:
    """The variable written as ``name``, or None (a derived field such as von_mises)."""
    return next((v for v in STATE if v.output == name), None)
