"""Several materials in one body: one :class:`~fenics_plast.material.Material` per set of cells.

>>> mats = MaterialRegions([(steel, cells_a), (copper, cells_b)], n_cells)   # owned cells of this rank
>>> mats.update_into(Fu, binv_n, eqps_n, tau, binv, eqps, a)                   # as Material.update_into

The points are cell-major, as in :class:`fenics_plast.quadrature.QuadratureMap`: point p belongs to
owned cell p // nq (nq points per cell, nq = n_points / n_cells). Each material updates its own
points: they are gathered into contiguous work arrays, run through the same kernel as a single
material (:func:`fenics_plast.material.kernels.update_points`, so each point gets the numbers it
would get in a body made of its material alone) and scattered back. A body of one material does not
use this class: solvers take the plain :class:`Material` (no gather, no scatter).
"""
from __future__ import annotations

import numba
import numpy as np

from . import kernels
from .update_arrays import AllocatingUpdates

__all__ = ["MaterialRegions", "update_regions"]

_njit = numba.njit(cache=True, fastmath={"contract", "arcp", "nsz"}, nogil=True)


@_njit
def update_regions(order, offsets, models, lams, mus, laws, hps, tols, Fu, binv_n, eqps_n, temp_n, dt, tau, binv,
                   eqps, temp, a, want_tangent, Fu_b, B_b, e_b, T_b, tau_b, a_b):
    """Update every point with its own material (the tables of :meth:`MaterialRegions.kernel_args`).

    order (n,), offsets (nmat + 1,): the points of material m are order[offsets[m]:offsets[m + 1]].
    Fu, binv_n (n,3,3), eqps_n, temp_n (n,) in; tau, binv (n,3,3), eqps, temp (n,) out, a (n,3,3,3,3)
    out when want_tangent (a dummy otherwise); binv may be binv_n, eqps eqps_n, temp temp_n (in place).
    dt: the increment's time [s] (Johnson-Cook; <= 0: static convention); the temperature of a point
    whose material has no temperature state is copied through.
    Fu_b, B_b, tau_b (m,3,3), e_b, T_b (m,), a_b (m,3,3,3,3) (m >= the largest material's point count;
    a_b may be (1,3,3,3,3) without tangent): work arrays. Returns the number of points that yielded.
    """
    nplastic = 0
    for m in range(models.shape[0]):
        lo = offsets[m]
        k = offsets[m + 1] - lo
        for j in range(k):
            p = order[lo + j]
            for r in range(3):
                for s in range(3):
                    Fu_b[j, r, s] = Fu[p, r, s]
                    B_b[j, r, s] = binv_n[p, r, s]
            e_b[j] = eqps_n[p]
            T_b[j] = temp_n[p]
        ab = a_b[:k] if want_tangent else a_b[:1]
        nplastic += kernels.update_points(models[m], Fu_b[:k], B_b[:k], e_b[:k], T_b[:k], lams[m], mus[m],
                                          laws[m], hps[m], tols[m], dt, tau_b[:k], B_b[:k], e_b[:k], T_b[:k], ab,
                                          want_tangent)
        for j in range(k):
            p = order[lo + j]
            for r in range(3):
                for s in range(3):
                    tau[p, r, s] = tau_b[j, r, s]
                    binv[p, r, s] = B_b[j, r, s]
            eqps[p] = e_b[j]
            temp[p] = T_b[j]
            if want_tangent:
                for r in range(3):
                    for s in range(3):
                        for t in range(3):
                            for v in range(3):
                                a[p, r, s, t, v] = a_b[j, r, s, t, v]
    return nplastic


class MaterialRegions(AllocatingUpdates):
    """Materials per set of cells, with the interface the solvers use from a :class:`Material`.

    Parameters
    ----------
    parts : sequence of (Material, cells): ``cells`` are local indices of owned cells
        (0 <= c < n_cells) of this rank; every owned cell must be in exactly one part
        (ValueError otherwise). A part may hold no cell of this rank.
    n_cells : number of owned cells of this rank.

    Attributes: ``materials`` (list), ``cells`` (list of sorted int arrays, one per material),
    ``cell_material`` (n_cells,) int64: the material index of each owned cell; ``E`` the largest
    Young's modulus [MPa] (default contact penalties); ``model`` the models' names ("seed",
    "isochoric" or both joined by "+"); ``thermal``: some material has a temperature state
    (Johnson-Cook). There is no single ``lame``: see :meth:`per_cell`.
    """

    def __init__(self, parts, n_cells: int):
        parts = list(parts)
        if not parts:
            raise ValueError("MaterialRegions needs at least one (material, cells) part")
        self.n_cells = int(n_cells)
        self.materials = [m for m, _ in parts]
        cells = [np.asarray(c, dtype=np.int64).reshape(-1) for _, c in parts]
        allc = np.concatenate(cells)
        if allc.size and (allc.min() < 0 or allc.max() >= self.n_cells):
            raise ValueError(f"cell indices must lie in 0..{self.n_cells - 1} (owned cells of this rank)")
        count = np.bincount(allc, minlength=self.n_cells)
        if (count > 1).any():
            raise ValueError(f"{int((count > 1).sum())} cells are given to more than one material (or twice)")
        if (count == 0).any():
            raise ValueError(f"{int((count == 0).sum())} of {self.n_cells} cells have no material")
        self.cell_material = np.empty(self.n_cells, dtype=np.int64)
        for k, c in enumerate(cells):
            self.cell_material[c] = k
        self.cells = [np.sort(c) for c in cells]
        args = [m.kernel_args() for m in self.materials]          # (model, lmbda, mu, law, hp, tol)
        width = max(a[4].size for a in args)
        hps = np.zeros((len(args), width))
        for k, a in enumerate(args):
            hps[k, : a[4].size] = a[4]
        self._tables = (np.array([a[0] for a in args], dtype=np.int64), np.array([a[1] for a in args]),
                        np.array([a[2] for a in args]), np.array([a[3] for a in args], dtype=np.int64),
                        hps, np.array([a[5] for a in args]))
        self.E = max(m.E for m in self.materials)
        self.thermal = any(m.thermal for m in self.materials)
        self.model = "+".join(sorted({m.model for m in self.materials}))
        self._layouts = {}                  # nq -> point_layout(nq)
        self._tangent_work = {}             # nq -> tangent work array of update_into
        self._no_tangent = np.zeros((1, 3, 3, 3, 3))

    def __len__(self):
        return len(self.materials)

    def per_cell(self, values) -> np.ndarray:
        """(n_cells,) array of a per-material value (one per material, in order), e.g. densities."""
        values = np.asarray(values, dtype=float).reshape(-1)
        if values.size != len(self.materials):
            raise ValueError(f"{values.size} values given for {len(self.materials)} materials")
        return values[self.cell_material]

    def wave_speeds(self, densities) -> np.ndarray:
        """Dilatational wave speed of each material [mm/s] for its density [tonne/mm^3] (one per
        material); :meth:`per_cell` spreads them over the cells."""
        densities = np.asarray(densities, dtype=float).reshape(-1)
        if densities.size != len(self.materials):
            raise ValueError(f"{densities.size} densities given for {len(self.materials)} materials")
        return np.array([m.wave_speed(float(r)) for m, r in zip(self.materials, densities)])

    def initial_temperatures(self, n: int) -> np.ndarray:
        """(n,) temperatures [K] of n virgin points (cell-major), each its material's
        :attr:`Material.initial_temperature` (0 for a material without temperature state)."""
        nq = self._nq(int(n))
        t0 = np.array([m.initial_temperature for m in self.materials])
        return np.repeat(t0[self.cell_material], nq)

    def kernel_args(self) -> tuple:
        """Per-material tables in the order of :meth:`Material.kernel_args`: models (nmat,) int64,
        lmbda, mu (nmat,) [MPa], hardening codes (nmat,) int64, hardening parameters (nmat, k)
        (rows padded with zeros), yield tolerances (nmat,)."""
        return self._tables

    def point_layout(self, nq: int) -> tuple:
        """(order, offsets, Fu_b, B_b, e_b, T_b, tau_b) for ``nq`` points per cell: the points of material
        m are order[offsets[m]:offsets[m + 1]] (cell-major numbering), and work arrays for
        :func:`update_regions` sized for the largest material. Cached per nq; the arrays are reused
        by every call (not thread-safe)."""
        lay = self._layouts.get(nq)
        if lay is None:
            q = np.arange(nq, dtype=np.int64)
            pts = [(c[:, None] * nq + q[None, :]).reshape(-1) for c in self.cells]
            order = np.concatenate(pts).astype(np.int64)
            offsets = np.concatenate([[0], np.cumsum([p.size for p in pts])]).astype(np.int64)
            m = max(1, max(p.size for p in pts))
            lay = (order, offsets, np.zeros((m, 3, 3)), np.zeros((m, 3, 3)), np.zeros(m), np.zeros(m),
                   np.zeros((m, 3, 3)))
            self._layouts[nq] = lay
        return lay

    def _nq(self, n: int) -> int:
        if self.n_cells == 0:
            if n:
                raise ValueError(f"{n} points given for 0 cells")
            return 1
        if n % self.n_cells:
            raise ValueError(f"{n} points are not a whole number per cell ({self.n_cells} cells)")
        return n // self.n_cells

    def update_into(self, Fu, binv_n, eqps_n, tau, binv, eqps, a=None, temp_n=None, temp=None, dt=0.0) -> int:
        """Constitutive update of the n = n_cells nq points (cell-major) into preallocated arrays, each
        point with its cell's material (see :meth:`Material.update_into`; temp_n None: the initial
        temperatures, temp None: not kept). Returns the number of points that yielded."""
        nq = self._nq(Fu.shape[0])
        order, offsets, Fu_b, B_b, e_b, T_b, tau_b = self.point_layout(nq)
        if temp_n is None:
            temp_n = self.initial_temperatures(Fu.shape[0])
        if temp is None:
            temp = np.empty(Fu.shape[0])
        want = a is not None
        if want:
            a_b = self._tangent_work.get(nq)
            if a_b is None:
                a_b = self._tangent_work[nq] = np.zeros((Fu_b.shape[0], 3, 3, 3, 3))
        else:
            a = a_b = self._no_tangent
        return update_regions(order, offsets, *self._tables, Fu, binv_n, eqps_n, temp_n, float(dt), tau, binv, eqps,
                              temp, a, want, Fu_b, B_b, e_b, T_b, tau_b, a_b)

    def energy(self, binv) -> np.ndarray:
        """Stored elastic energy per reference volume [MPa = mJ/mm^3] of each point with its cell's
        material, shape (n,)."""
        binv = np.ascontiguousarray(binv, dtype=float).reshape(-1, 3, 3)
        order, offsets = self.point_layout(self._nq(binv.shape[0]))[:2]
        out = np.empty(binv.shape[0])
        for m, mat in enumerate(self.materials):
            p = order[offsets[m]:offsets[m + 1]]
            out[p] = mat.energy(binv[p])
        return out

    def __repr__(self):
        parts = ", ".join(f"{m!r}: {c.size} cells" for m, c in zip(self.materials, self.cells))
        return f"MaterialRegions({parts})"
