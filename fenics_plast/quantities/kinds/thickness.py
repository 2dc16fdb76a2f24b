"""thickness (2-D only): the profile ln(t/t0) between two facing facet groups along the first,
written to ``<name>.csv`` at every step end and summarised by its smallest value, where it is
(reference coordinate s0 [mm]) and its value at the start of the group."""
from __future__ import annotations

import numpy as np

from fenics_plast.scene_key import REQUIRED, Key

NAME, ORDER = "thickness", 90
DOC = ("thickness (2-D only): ln(t/t0) between two facing groups along the first (a profile, written to "
       "<name>.csv at every step end)")
TAKES = ("group",)
PROFILE = True
KEYS = {
    "opposite": Key("str", REQUIRED, "The facing group (thickness)."),
}


def columns(name, o):
    return []          # a profile, no history column


def check(d, o, ctx, fail):
    if o.group is None:
        fail(f"{d}.group is missing: required for a thickness profile")


def check_mesh(d, o, ctx, fail):
    if ctx["three_d"]:
        fail(f"{d}.quantity = 'thickness' is a 2-D profile: not available {ctx['where']} (use position or "
             f"extent outputs)")


def setup(name, o, q):
    b = q.body
    q.nodes[name] = b.group_nodes(q.facet_tags, q.groups[o.group][1])
    q.nodes[name + "/opposite"] = b.group_nodes(q.facet_tags, q.groups[o.opposite][1])
    q.profiles[name] = []


def profile(name, q) -> tuple[np.ndarray, np.ndarray]:
    """(reference coordinate along the group, ln(t / t0)) at the group's nodes, all ranks.
    The facing node is matched by the reference coordinate along the group (interpolated)."""
    a, c = gather(q, q.nodes[name]), gather(q, q.nodes[name + "/opposite"])
    # along: the coordinate in which the group extends most
    ax = int(np.argmax(np.ptp(a[:, :2], axis=0))) if len(a) > 1 else 0
    a = a[np.argsort(a[:, ax], kind="stable")]
    c = c[np.argsort(c[:, ax], kind="stable")]
    s = a[:, ax]
    if len(c) == len(a) and np.allclose(c[:, ax], s, atol=1e-8 * max(1.0, np.abs(s).max())):
        X2, x2 = c[:, :2], c[:, 2:4]
    else:
        X2 = np.column_stack([np.interp(s, c[:, ax], c[:, k]) for k in (0, 1)])
        x2 = np.column_stack([np.interp(s, c[:, ax], c[:, k]) for k in (2, 3)])
    t0 = np.linalg.norm(X2 - a[:, :2], axis=1)
    t = np.linalg.norm(x2 - a[:, 2:4], axis=1)
    return s, np.log(t / t0)


def gather(q, nodes):
    """(reference x, y, current x, y) of ``nodes``, all ranks, each node once."""
    b = q.body
    x = b.positions()[nodes]
    a = np.hstack([b.X[nodes], x]) if len(nodes) else np.zeros((0, 4))
    a = np.vstack(b.comm.allgather(a))
    _, keep = np.unique(np.round(a[:, :2], 9), axis=0, return_index=True)
    return a[np.sort(keep)]


def summary(name, o, q, time_label) -> dict:
    res = {}
    if not q.profiles[name]:
        return res
    for i, (t, s, v) in enumerate(q.profiles[name]):
        tag = "" if i == len(q.profiles[name]) - 1 else f"_at_{time_label}_{t:g}"
        k = int(np.argmin(v))
        res[f"min_{name}{tag}"] = float(v[k])
        res[f"s0_of_min_{name}{tag}_mm"] = float(s[k])
        res[f"{name}_at_start{tag}"] = float(v[0])
    return res


def summary_keys(name, o) -> list[str]:
    return [f"min_{name}", f"{name}_at_start"]
