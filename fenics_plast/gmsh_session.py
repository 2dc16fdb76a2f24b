"""One Gmsh session, as every reader of a Gmsh file in the package needs it (:mod:`fenics_plast.meshing`,
:mod:`fenics_plast.meshed_tools`): :func:`gmsh_session`."""
from __future__ import annotations

from contextlib import contextmanager

import gmsh


@contextmanager
def gmsh_session(log: bool = False):
    """Gmsh initialised, quiet, with a clear ONELAB database, finalized on leaving (``log``: its messages
    kept for ``gmsh.logger.get()`` meanwhile). ONELAB outlives ``gmsh.finalize()`` within a process: without
    the clearing, a .geo defining a parameter of the same name as one set for an earlier file
    (``Parameters/gap``) takes that value instead of its default."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.onelab.clear()
        if log:
            gmsh.logger.start()
        yield
    finally:
        if log:
            gmsh.logger.stop()
        gmsh.finalize()
