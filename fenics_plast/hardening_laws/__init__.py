"""The registry of isotropic hardening laws: one module per law in this package, each declaring
``LAW = HardeningLaw(...)``: its name, its integer code, its scene keys (``materials.<name>.hardening.*``,
with unit, range, default and meaning), how they pack into the float parameter vector the compiled
kernels read, and its flow stress and slope ``flow(p, eps_p) -> (sigma_y, dsigma_y/deps_p)`` [MPa].

A law module imports only the standard library and :mod:`fenics_plast.scene_key`: the schema reads
the declarations (importing it must not import numba). ``flow`` is plain Python written in the
subset numba compiles; :mod:`fenics_plast.material.hardening` compiles it and builds the dispatcher over
the codes. So the modules of this package hold code the kernels inline, and are part of the kernel
source digest (:func:`fenics_plast.kernel_source_digest`).

Adding a strain-only law is one new module here (plus its test): it is found by :func:`laws`, the
schema's ``hardening`` table and its ``law`` choices follow, and so does the compiled dispatcher.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable

from fenics_plast.declarations import gathered
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key

__all__ = ["HardeningLaw", "laws"]


@dataclass(frozen=True)
class HardeningLaw:
    """One hardening law's declaration.

    name : the scene's ``hardening.law`` value. code : the integer the kernels dispatch on (unique).
    doc : the formula, one paragraph (the schema's table doc and the key reference show it).
    params : {scene key: :class:`~fenics_plast.scene_key.Key`} without ``when`` (the schema adds it);
        a key shared by several laws must be declared alike by each but for its doc.
    flow : (p, eps_p) -> (sigma_y, dsigma_y/deps_p) [MPa], numba-compilable; None for a law whose
        flow stress needs more than eps_p (Johnson-Cook: the kernels treat it themselves).
    pack : {key: value} (every declared key present, defaults filled in, other keywords passed
        through) -> the parameter list; None: the values of ``params`` in their order.
    thermal : the law has a temperature state.
    check : (dotted, material, fail) -> None, the scene rules of the law beyond each key's own range, run
        by the scene validation: ``dotted`` is ``materials.<name>``, ``material`` that validated table
        (attributes ``hardening``, ``density``, ...), ``fail(message)`` reports an error (raises); None: none.
    """
    name: str
    code: int
    doc: str
    params: dict[str, Key]
    flow: Callable | None = None
    pack: Callable[[dict], list] | None = None
    thermal: bool = False
    check: Callable[[str, Any, Callable[[str], None]], None] | None = None

    def vector(self, kw: dict) -> list:
        """The parameter list of the keyword values ``kw`` (missing keys take their declared default;
        a missing required key is a KeyError; keywords the law does not declare are passed to ``pack``)."""
        values = dict(kw)
        for name, key in self.params.items():
            if name not in values:
                if key.default is REQUIRED:
                    raise KeyError(f"{self.name} hardening needs {name!r}")
                values[name] = None if key.default is OPTIONAL else key.default
        if self.pack is not None:
            return self.pack(values)
        return [values[name] for name in self.params]


@functools.lru_cache(maxsize=None)
def _registry() -> tuple[HardeningLaw, ...]:
    return gathered(__name__, __path__, "LAW", HardeningLaw, "hardening laws")


def laws() -> dict[str, HardeningLaw]:
    """{name: law} of every law module in this package, in the order of their codes."""
    return {law.name: law for law in _registry()}
