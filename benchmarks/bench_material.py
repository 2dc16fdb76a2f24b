"""Material-update throughput (quadrature points per second), single thread.

    python benchmarks/bench_material.py [--points 1e3 1e4 1e5 1e6] [--repeats 7] [--plastic 0.9]

Implementations: the numba kernels (seed and isochoric models) and the vectorised numpy
reference (seed model, closed-form linear hardening), each with and without the spatial
consistent tangent.  Copper of the Taylor bar (E = 117 GPa, nu = 0.35, sigma_y = 400 MPa,
H = 100 MPa).  Inputs: random increments F_u near identity, a fraction ``--plastic`` of
the points loaded beyond yield, the rest well inside the elastic range.  Outputs are
preallocated; a warm-up call excludes JIT compilation; the best of ``--repeats`` runs is
reported.  This is a benchmark, not a test: it asserts nothing.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # single thread (before numpy/numba are imported)

import numba  # noqa: E402
import numpy as np  # noqa: E402

from fenics_plast.material import Hardening, Material  # noqa: E402
from fenics_plast.material.numpy_reference import update_material  # noqa: E402

TARGET_TANGENT = 3e6   # points/s per core, with tangent, at 1e5 points
TARGET_NO_TANGENT = 6e6  # without tangent
TARGET_POINTS = 100_000


def make_inputs(n: int, plastic: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    Fu = np.eye(3) + 0.01 * rng.standard_normal((n, 3, 3))          # ~1 % strain: beyond yield (0.34 %)
    elastic = rng.random(n) >= plastic
    Fu[elastic] = np.eye(3) + 2e-4 * rng.standard_normal((int(elastic.sum()), 3, 3))
    binv_n = np.repeat(np.eye(3)[None], n, axis=0)
    eqps_n = np.abs(0.01 * rng.standard_normal(n))
    return Fu, binv_n, eqps_n


def throughput(fn, n: int, repeats: int, min_time: float = 0.05) -> float:
    """Best points/s over repeats; each repeat loops fn enough times to last >= min_time."""
    fn()  # warm-up (JIT compile, page faults on the outputs)
    t0 = time.process_time()
    fn()
    once = max(time.process_time() - t0, 1e-9)
    inner = max(1, int(min_time / once))
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(inner):
            fn()
        best = min(best, (time.process_time() - t0) / inner)
    return n / best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=float, nargs="+", default=[1e3, 1e4, 1e5, 1e6])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--plastic", type=float, default=0.9, help="fraction of points loaded beyond yield")
    args = ap.parse_args(argv)

    law = Hardening("linear", yield_stress=400.0, modulus=100.0)
    impls = {
        "numba seed": (Material(117e3, 0.35, law, "seed"), None),
        "numba isochoric": (Material(117e3, 0.35, law, "isochoric"), None),
        "numpy seed": (Material(117e3, 0.35, law, "seed"), update_material),
    }
    print(f"material update throughput, points/s (single thread, best of {args.repeats}, CPU time of this process); "
          f"numpy {np.__version__}, numba {numba.__version__}, {platform.processor() or platform.machine()}, "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    header = f"{'points':>9} {'implementation':<16} {'plastic':>7} {'with tangent':>13} {'no tangent':>13}"
    print(header)
    print("-" * len(header))
    results = {}
    for npts in args.points:
        n = int(npts)
        Fu, binv_n, eqps_n = make_inputs(n, args.plastic)
        tau, binv, eqps = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty(n)
        a = np.empty((n, 3, 3, 3, 3))
        for name, (mat, ref) in impls.items():
            row = {}
            nplastic = 0
            for tangent in (True, False):
                aa = a if tangent else None
                if ref is None:
                    def fn(mat=mat, aa=aa):
                        return mat.update_into(Fu, binv_n, eqps_n, tau, binv, eqps, aa)
                else:
                    def fn(mat=mat, aa=aa, ref=ref):
                        return ref(mat, Fu, binv_n, eqps_n, tau, binv, eqps, aa)
                nplastic = fn()
                row[tangent] = throughput(fn, n, args.repeats)
            results[(n, name)] = row
            print(f"{n:>9} {name:<16} {nplastic / n:>7.0%} {row[True]:>13.3e} {row[False]:>13.3e}", flush=True)
    if TARGET_POINTS in [int(p) for p in args.points]:
        print(f"\ntargets at {TARGET_POINTS:.0e} points: >= {TARGET_TANGENT:.0e}/s with tangent, "
              f">= {TARGET_NO_TANGENT:.0e}/s without")
        for name in impls:
            row = results[(TARGET_POINTS, name)]
            ok_t, ok_n = row[True] >= TARGET_TANGENT, row[False] >= TARGET_NO_TANGENT
            print(f"  {name:<16} with tangent {'MET' if ok_t else 'missed'} ({row[True] / TARGET_TANGENT:.2f}x), "
                  f"without {'MET' if ok_n else 'missed'} ({row[False] / TARGET_NO_TANGENT:.2f}x)")


if __name__ == "__main__":
    main()
