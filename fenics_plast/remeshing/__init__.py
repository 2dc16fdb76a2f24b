"""Automatic 2-D remeshing of deformed quadrilateral meshes (issue 35): the pieces, not yet called by
the runners.

* :mod:`~fenics_plast.remeshing.quality`: per-cell scaled Jacobian, corner angles and aspect ratio of
  the deformed mesh, and the collective decision to remesh (:func:`should_remesh`, thresholds with
  defaults);
* :mod:`~fenics_plast.remeshing.outline`: the deformed body's boundary (outer loops, holes, region
  interfaces) as polylines cut where a facet group changes and at corners, each piece carrying its
  group names (rank 0);
* :mod:`~fenics_plast.remeshing.new_mesh`: the outline meshed anew in Gmsh, all quadrilaterals, of a
  size h refined near given points, the old groups and regions carried over; unpacks like
  :func:`fenics_plast.meshing.mesh_from_file`;
* :mod:`~fenics_plast.remeshing.transfer`: the quadrature state (b_e^-1 through its logarithm, so it
  stays symmetric positive definite; scalars clipped to the old range), P0 and CG1 fields carried from
  the old mesh onto the new one, with the transfer's diagnostics.

Wiring them into the static and explicit runs (the solver rebuilt on the new mesh, re-equilibration,
output, checkpoints across remeshes) is what remains of issue 35.
"""
