r"""Vectorised numpy implementation of the seed model with linear hardening.

An independent implementation of :func:`fenics_plast.material.kernels.update_points` for
``model=SEED`` and the ``linear`` hardening law (or no hardening: hyperelastic), used to
cross-check the numba kernel and to measure numpy against numba (``benchmarks/bench_material.py``).
It works on whole arrays (n,3,3), chunk by chunk (``chunk`` points at a time, so that the
temporaries stay in cache), with the closed-form radial return of linear hardening:

    ``Fi  = Fu^-1``                                              (cofactors)
    ``bt  = Fi^T binv_n Fi``                                     (11)
    ``e   = 1/2 (I - bt)``,  ``tau_tr = lmbda tr(e) I + 2 mu e``   (7), (9)
    ``s   = dev tau_tr = -mu dev bt``,  ``q_tr = sqrt(3/2 s:s)``
    ``f   = q_tr - (sigma_0 + H eps_n)``; yielding when ``f > yield_tol sigma_y``
    ``dg  = f / (3 mu + H)``                                     (linear law, closed form)
    ``binv = bt + 3 dg/q_tr s``,  ``tau = (1 - 3 mu dg/q_tr) s + kappa tr(e) I``   (14)
    ``theta = 1 - 3 mu dg/q_tr``,  ``c = 6 mu^2 (1/(3 mu + H) - dg/q_tr)``,  ``N = s/|s|``
    ``a_ijkl = (kappa - 2 mu theta/3) d_ij bt_lk + mu theta (d_il bt_jk + d_jl bt_ik) - c N_ij (N bt)_lk``
"""
from __future__ import annotations

import numpy as np

__all__ = ["update_seed_linear", "update_material"]

_I = np.eye(3)


def _inverse3(A, out):
    """Batched inverse of (m,3,3) matrices by cofactors, into out (m,3,3)."""
    a00, a01, a02 = A[:, 0, 0], A[:, 0, 1], A[:, 0, 2]
    a10, a11, a12 = A[:, 1, 0], A[:, 1, 1], A[:, 1, 2]
    a20, a21, a22 = A[:, 2, 0], A[:, 2, 1], A[:, 2, 2]
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    r = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    out[:, 0, 0] = c00 * r
    out[:, 1, 0] = c01 * r
    out[:, 2, 0] = c02 * r
    out[:, 0, 1] = (a02 * a21 - a01 * a22) * r
    out[:, 1, 1] = (a00 * a22 - a02 * a20) * r
    out[:, 2, 1] = (a01 * a20 - a00 * a21) * r
    out[:, 0, 2] = (a01 * a12 - a02 * a11) * r
    out[:, 1, 2] = (a02 * a10 - a00 * a12) * r
    out[:, 2, 2] = (a00 * a11 - a01 * a10) * r
    return out


def update_seed_linear(Fu, binv_n, eqps_n, lmbda, mu, sigma_0, H, yield_tol, tau, binv, eqps, a=None,
                       chunk: int = 4096, plastic: bool = True) -> int:
    """Seed model, linear hardening sigma_y = sigma_0 + H eps_p, on n points (see the module docstring).

    Fu, binv_n (n,3,3), eqps_n (n,) -> tau, binv (n,3,3), eqps (n,), a (n,3,3,3,3) or None,
    all preallocated and C-contiguous.  plastic=False: hyperelastic (no return map).
    Returns the number of points that yielded.
    """
    n = Fu.shape[0]
    kap = lmbda + 2.0 * mu / 3.0
    nplastic = 0
    m = min(chunk, n)
    Fi = np.empty((m, 3, 3))
    bt = np.empty((m, 3, 3))
    s = np.empty((m, 3, 3))
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        k = stop - start
        Fi_, bt_, s_ = Fi[:k], bt[:k], s[:k]
        # elastic predictor (11)
        _inverse3(Fu[start:stop], Fi_)
        np.matmul(Fi_.transpose(0, 2, 1), np.matmul(binv_n[start:stop], Fi_), out=bt_)
        for i, j in ((0, 1), (0, 2), (1, 2)):  # exact symmetry: upper triangle mirrored, as the kernel
            bt_[:, j, i] = bt_[:, i, j]
        # trial stress (7), (9): p = kappa tr(e), s = dev(2 mu e) = -mu dev(bt)
        tr_e = 0.5 * (3.0 - bt_[:, 0, 0] - bt_[:, 1, 1] - bt_[:, 2, 2])
        p = kap * tr_e
        np.multiply(bt_, -mu, out=s_)
        s_ += mu * _I
        mean = np.trace(s_, axis1=1, axis2=2) / 3.0
        s_ -= mean[:, None, None] * _I
        ss = np.einsum("qij,qij->q", s_, s_)
        q_tr = np.sqrt(1.5 * ss)
        # radial return, closed form for linear hardening
        eps_n = eqps_n[start:stop]
        dg = np.zeros(k)
        if plastic:
            sy_n = sigma_0 + H * eps_n
            yld = (q_tr - sy_n > yield_tol * np.maximum(sy_n, 1e-300)) & (q_tr != 0.0)
            dg[yld] = (q_tr[yld] - sy_n[yld]) / (3.0 * mu + H)
            nplastic += int(np.count_nonzero(yld))
        else:
            yld = np.zeros(k, dtype=bool)
        fac = np.zeros(k)
        fac[yld] = 3.0 * dg[yld] / q_tr[yld]
        theta = 1.0 - mu * fac
        c = np.zeros(k)
        c[yld] = 6.0 * mu * mu * (1.0 / (3.0 * mu + H) - dg[yld] / q_tr[yld])
        # plastic corrector (14)
        np.add(bt_, fac[:, None, None] * s_, out=binv[start:stop])
        np.add(theta[:, None, None] * s_, p[:, None, None] * _I, out=tau[start:stop])
        eqps[start:stop] = eps_n + dg
        if a is None:
            continue
        # spatial tangent
        #   a_ijkl = (kappa - 2 mu theta/3) d_ij bt_lk + mu theta (d_il bt_jk + d_jl bt_ik) - c N_ij (N bt)_lk
        ac = a[start:stop]
        c1 = (kap - 2.0 * mu * theta / 3.0)[:, None, None, None, None]
        c2 = (mu * theta)[:, None, None, None, None]
        btT = bt_.transpose(0, 2, 1)  # btT[q,k,l] = bt_lk
        np.multiply(c1 * _I[None, :, :, None, None], btT[:, None, None, :, :], out=ac)      # d_ij bt_lk
        ac += c2 * _I[None, :, None, None, :] * bt_[:, None, :, :, None]                   # d_il bt_jk
        ac += c2 * _I[None, None, :, None, :] * bt_[:, :, None, :, None]                   # d_jl bt_ik
        if np.any(yld):
            safe = np.where(ss > 0.0, ss, 1.0)
            NbT = np.matmul(s_, bt_).transpose(0, 2, 1)                                      # (s bt)_lk
            ac -= (c / safe)[:, None, None, None, None] * s_[:, :, :, None, None] * NbT[:, None, None, :, :]
    return nplastic


def update_material(mat, Fu, binv_n, eqps_n, tau, binv, eqps, a=None, chunk: int = 4096) -> int:
    """:meth:`Material.update_into` for a seed-model Material with linear (or no) hardening."""
    if mat.model != "seed":
        raise ValueError(f"numpy reference implements the seed model only, got {mat.model!r}")
    lmbda, mu = mat.lame
    h = mat.hardening
    if h is None:
        return update_seed_linear(Fu, binv_n, eqps_n, lmbda, mu, 0.0, 0.0, mat.yield_tol, tau, binv, eqps, a,
                                  chunk=chunk, plastic=False)
    if h.law != "linear":
        raise ValueError(f"numpy reference implements linear hardening only, got {h.law!r}")
    return update_seed_linear(Fu, binv_n, eqps_n, lmbda, mu, float(h.params[0]), float(h.params[1]),
                              mat.yield_tol, tau, binv, eqps, a, chunk=chunk)
