"""What a run writes from its solver besides the history rows: fields.xdmf opened with the mesh, the
checkpointer of ``output.checkpoint_every`` / ``--resume``, final_shape.csv (deformed cells and their
mean eqps [-], temperature [K]), the declared plots, and the contact pairs' penetration reports
(penetration [mm] over the depth [mm] of the cells along the group, warnings naming the penalty
[N/mm^3]). Shared by :mod:`fenics_plast.runner_static` and :mod:`fenics_plast.runner_explicit`.
"""
from __future__ import annotations

import os
import sys

from dolfinx import io

from fenics_plast.checkpoint import Checkpointer, scene_settings

__all__ = ["open_fields", "contact_fields", "checkpointer", "write_final_shape", "draw_plots", "penetration_report",
           "warn", "PENETRATION_WARNING"]


#: a contact pair whose largest penetration exceeds this fraction of the depth of the cells along its
#: group is reported as not to be trusted (log and summary.json "warnings")
PENETRATION_WARNING = 0.05


def warn(comm, msg: str) -> None:
    """A warning line on stderr (rank 0), whatever the progress display (FENICS_PLAST_PROGRESS=off too)."""
    if comm is None or comm.rank == 0:
        print(f"warning: {msg}", file=sys.stderr, flush=True)


def penetration_report(name, penetration, depth, penalty, default_penalty, comm) -> dict:
    """summary.json entries of contact pair ``name``: its largest penetration [mm] over the depth [mm]
    of the cells along its group (``<name>_penetration_per_cell_depth``) and, above
    PENETRATION_WARNING, a warning (:func:`warn`, and in the list "warnings") naming the penalty used
    and the pair's default one [N/mm^3]."""
    ratio = penetration / depth if depth > 0 else 0.0
    out = {f"{name}_penetration_per_cell_depth": ratio, "warnings": []}
    if ratio > PENETRATION_WARNING:
        if penalty < default_penalty:
            cause = (f"the penalty {penalty:.3g} N/mm^3 is too soft for this load (this pair's default is "
                     f"{default_penalty:.3g} N/mm^3)")
        else:
            cause = (f"the penalty {penalty:.3g} N/mm^3 ({penalty / default_penalty:.3g} times this pair's default) "
                     f"is still too soft for this load: a stiffer one (explicit: a shorter stable step) or finer "
                     f"cells along the group lower it")
        msg = (f"contact.{name}: the largest penetration, {penetration:.3g} mm, is {100 * ratio:.3g} % of the "
               f"depth of the cells along its group ({depth:.3g} mm; more than {100 * PENETRATION_WARNING:g} %): "
               f"{cause}; its forces and the shape near it cannot be trusted to better than that")
        warn(comm, msg)
        out["warnings"].append(msg)
    return out


def _claim(output, *names) -> None:
    """``output.claim(names)`` (the marker's list of the run's files) when the output keeps one."""
    claim = getattr(output, "claim", None)
    if claim is not None:
        claim(*names)


def open_fields(problem, output, comm, mesh, name="fields"):
    """The XDMF file of the run's fields on ``mesh`` (None when output.xdmf is off), ``<name>.xdmf``:
    fields.xdmf, or fields_remesh<k>.xdmf for the k-th new mesh of a remeshed run (collective)."""
    if not problem.output.xdmf:
        return None
    failed = None
    path = output.xdmf_path.with_name(f"{name}.xdmf")
    if comm.rank == 0:          # HDF5 follows links and truncates in place: no link, a new file (out_files)
        from fenics_plast.out_files import remove_file
        _claim(output, path.name, path.with_suffix(".h5").name)
        for p in (path, path.with_suffix(".h5")):
            if os.path.lexists(p) and not (os.path.isfile(p) and not os.path.islink(p)):
                failed = (f"{p}: is a symbolic link (or not a regular file): fenics-plast does not write through "
                          f"it; remove it, or choose another output folder")
                break
            remove_file(p)
    failed = comm.bcast(failed, root=0) if comm.size > 1 else failed
    if failed:
        from fenics_plast.out_files import LinkRefused
        raise LinkRefused(failed)
    xf = io.XDMFFile(comm, str(path), "w")
    xf.write_mesh(mesh)
    return xf


def contact_fields(b, V) -> list:
    """The contact fields of the run ``b``'s pairs (``b.pairs``) on the displacement space ``V``, updated to the
    present state (:class:`fenics_plast.contact_fields.ContactFields`, made once per build: a remeshed run's
    new build gets its own); [] without pairs. Collective."""
    if not b.pairs:
        return []
    if getattr(b, "contact_fields", None) is None:
        from fenics_plast.contact_fields import ContactFields
        b.contact_fields = ContactFields(b.pairs, V)
    b.contact_fields.update()
    return b.contact_fields.functions


def checkpointer(problem, output, comm):
    every = int(problem.output.checkpoint_every)
    resume = bool(getattr(output, "resume", False))
    if not (every > 0 or resume):
        return None
    return Checkpointer(output.out_dir, comm, scene_settings(problem), problem.analysis.type, every=every,
                        resume=resume, output=output)


def write_final_shape(problem, output, V, positions, qmap, thermal=None):
    """final_shape.csv (deformed cells and the cell means of the written state variables: eqps, and
    temperature with Johnson-Cook or Hensel-Spittel materials) when the scene declares a shape plot; with
    ``thermal`` (a [thermal] run's ThermalCoupling) the temperature is the field's, its cell means at the
    quadrature points; collective."""
    if not any(p.type == "shape" for p in problem.plots.values()):
        return
    from fenics_plast.plots import cells_table
    table = None
    fields = qmap.fields()
    if thermal is not None:
        fields["temperature"] = qmap.cell_mean(thermal.points_temperature(), name="temperature")
    for name, fun in fields.items():
        column = cells_table(V, positions, fun, name)
        if table is None:
            table = column
        else:
            table[name] = column[name]
    output.write_csv("final_shape", table)


def start_plot_worker(problem, output):
    """Start the process that will draw the scene's plots (rank 0, when the scene has plots), so that it
    imports matplotlib while the run computes: ``output.plot_worker``, used by :func:`draw_plots`;
    :func:`stop_plot_worker` lets it go if the run ends without drawing."""
    output.plot_worker = None
    if problem.output.plots and output.is_root and problem.plots:
        from fenics_plast.plot_worker import PlotWorker
        try:
            output.plot_worker = PlotWorker()
        except OSError:         # no process to spare: the plots are drawn in process
            output.plot_worker = None


def stop_plot_worker(output):
    worker = getattr(output, "plot_worker", None)
    if worker is not None:
        output.plot_worker = None
        worker.close()


def draw_plots(problem, output):
    """The scene's [plots] as PNGs (rank 0); a figure that fails is logged and does not fail the run."""
    if not problem.output.plots or not output.is_root or not problem.plots:
        return
    from fenics_plast.plots import declared_figures
    from fenics_plast.quantities import study_keys
    output.close_history()
    _claim(output, *(f"{fig.name}.png" for fig in declared_figures(problem.to_dict())))
    args = (output.out_dir, problem.to_dict(), problem.name, study_keys(problem.outputs)["references"])
    try:
        worker = getattr(output, "plot_worker", None)
        output.plot_worker = None
        if worker is not None:          # started with the run (start_plot_worker): matplotlib is imported
            from fenics_plast.plot_worker import WorkerLost
            try:
                worker.draw(*args)
                return
            except WorkerLost as e:
                output.log(f"warning: {e}; drawing the plots in this process")
        from fenics_plast.plots import draw_declared
        draw_declared(args[0], args[1], title=args[2], references=args[3])
    except Exception as e:  # noqa: BLE001 - plots are a by-product; the results stand
        output.log(f"warning: plots of {output.out_dir} not drawn: {type(e).__name__}: {e}")
