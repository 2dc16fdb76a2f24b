"""Signed gaps to faceted surfaces (fenics_plast.solvers.surface_gaps): the hierarchy search against a search
over all facets, the sign from pseudo-normals on either side of convex and concave features, and
triangulated spheres and polygonal circles against their analytic gaps."""
import math

import numpy as np
import pytest

from fenics_plast.solvers.surface_gaps import build_surface, surface_gaps


def icosphere(radius: float, subdivisions: int):
    """(vertices, triangles) of a sphere about the origin, outward-oriented: an icosahedron subdivided."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
         (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    V = [np.array(v, dtype=float) / np.linalg.norm(v) for v in V]
    for _ in range(subdivisions):
        mid, F2 = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                mid[key] = len(V) - 1
            return mid[key]
        for a, b, c in F:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            F2 += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = F2
    return radius * np.array(V), np.array(F)


def brute_force(V, F, x):
    """The unsigned distance of each point x (n, dim) to the surface, the smallest over every facet (the
    compiled nearest-point formulas, without the hierarchy)."""
    from fenics_plast.solvers.surface_gaps import segment_nearest, triangle_nearest
    out = np.empty(len(x))
    for i, p in enumerate(x):
        if V.shape[1] == 2:
            out[i] = math.sqrt(min(segment_nearest(p, V, a, b)[0] for a, b in F))
        else:
            out[i] = math.sqrt(min(triangle_nearest(p, V, a, b, c)[0] for a, b, c in F))
    return out


def test_sphere_gaps_match_the_search_over_all_facets_and_the_sphere():
    """Points inside, outside, near and far from a triangulated sphere (R = 10 mm, 1280 triangles): the
    hierarchy search finds the nearest facet (distance equal to the search over all facets to 1e-12), the sign
    is the side of the sphere, and g is the sphere's own gap |x| - R to within the facets' sagitta."""
    R = 10.0
    V, F = icosphere(R, 3)
    s = build_surface(V, F, flip=False)
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(400, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    radii = np.concatenate([rng.uniform(0.2, 0.99, 100), rng.uniform(0.999, 1.001, 100),
                            rng.uniform(1.01, 1.5, 100), rng.uniform(3.0, 8.0, 100)]) * R
    x = dirs * radii[:, None]
    g, N = surface_gaps(s, x)
    assert np.allclose(np.abs(g), brute_force(V, F, x), rtol=0, atol=1e-12 * R)
    exact = radii - R
    sagitta = R * (1 - math.cos(math.radians(2 * 63.4 / 2 ** 3)))      # edge angle of the subdivision, generous
    assert np.all(np.sign(g[np.abs(exact) > sagitta]) == np.sign(exact[np.abs(exact) > sagitta]))
    assert np.max(np.abs(g - exact)) < sagitta
    assert np.allclose(np.linalg.norm(N, axis=1), 1.0)
    outside = exact > sagitta
    assert np.min(np.einsum("ij,ij->i", N[outside], dirs[outside])) > 0.9    # N points away from the centre


def test_signs_at_convex_and_concave_edges_and_corners():
    """A unit cube's surface (12 triangles), flipped so that the body is inside (a cavity): points near its
    edges and corners, inside and out, get the sign of their side; the distance is the box's own."""
    V = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    outward = build_surface(V, F, flip=False)
    rng = np.random.default_rng(7)
    x = np.concatenate([rng.uniform(-0.3, 1.3, (3000, 3)),
                        np.array([[1.05, 1.05, 0.5], [0.95, 0.97, 0.5], [1.02, 1.03, 1.04], [0.98, 0.99, 0.97]])])
    inside = np.all((x > 0) & (x < 1), axis=1)
    outside_dist = np.linalg.norm(np.maximum(np.maximum(-x, x - 1), 0), axis=1)
    inside_dist = np.min(np.concatenate([x, 1 - x], axis=1), axis=1)
    exact = np.where(inside, -inside_dist, outside_dist)
    g, _ = surface_gaps(outward, x)
    orient = np.sign(np.mean(g[~inside]))          # which side the coherent orientation calls "outside"
    assert np.allclose(orient * g, exact, atol=1e-12)
    cavity = build_surface(V, F, flip=True)
    assert np.allclose(surface_gaps(cavity, x)[0], -orient * exact, atol=1e-12)


def test_polygon_circle_2d_and_a_concave_corner():
    """2-D: a polygon of 256 sides on a circle (R = 5 mm) against the circle's gap, at a search over all
    segments; an open L-shaped chain (a concave corner seen from the body) signs both sides right."""
    R, n = 5.0, 256
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    V = R * np.stack([np.cos(a), np.sin(a)], axis=1)
    F = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    s = build_surface(V, F, flip=False)
    rng = np.random.default_rng(11)
    r = rng.uniform(0.1, 3.0, 500) * R
    t = rng.uniform(0, 2 * math.pi, 500)
    x = np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
    g, N = surface_gaps(s, x)
    assert np.allclose(np.abs(g), brute_force(V, F, x), atol=1e-12 * R)
    orient = np.sign(g[r > 1.1 * R].mean())
    sagitta = R * (1 - math.cos(math.pi / n))
    assert np.max(np.abs(orient * g - (r - R))) <= sagitta * (1 + 1e-9)
    # the chain (2, 0) -> (0, 0) -> (0, 2): the body on the side x > 0, y > 0 (inside the corner)
    L = build_surface(np.array([[2.0, 0.0], [0.0, 0.0], [0.0, 2.0]]), np.array([[0, 1], [1, 2]]), flip=False)
    pts = np.array([[0.5, 0.5], [0.1, 1.5], [-0.3, -0.4], [-0.2, 1.0], [1.0, -0.2], [0.05, 0.02]])
    gL, NL = surface_gaps(L, pts)
    side = np.sign(gL[0])
    expect = np.array([0.5, 0.1, -0.5, -0.2, -0.2, 0.02])
    assert np.allclose(side * gL, expect, atol=1e-12)


def test_orientation_is_made_coherent_translation_and_reach():
    """Triangles given with random vertex orders give the same gaps as the coherent ones (up to the global
    side); a translated surface is the surface at the translated points; beyond reach g = reach, N = 0.
    Branching surfaces are refused."""
    V, F = icosphere(4.0, 2)
    rng = np.random.default_rng(5)
    flips = rng.random(len(F)) < 0.5
    F_mixed = np.where(flips[:, None], F[:, ::-1], F)
    x = rng.uniform(-8, 8, (300, 3))
    g1, _ = surface_gaps(build_surface(V, F, flip=False), x)
    g2, _ = surface_gaps(build_surface(V, F_mixed, flip=False), x)
    assert np.allclose(np.abs(g1), np.abs(g2), atol=1e-13) and abs(np.corrcoef(g1, g2)[0, 1]) > 0.999
    assert np.allclose(g1 * np.sign(g1 @ g2), g2, atol=1e-13)
    d = np.array([1.5, -2.0, 0.25])
    s = build_surface(V, F, flip=False)
    assert np.allclose(surface_gaps(s, x + d, d)[0], g1, atol=1e-12)
    g, N = surface_gaps(s, x, reach=1.0)
    far = np.abs(g1) > 1.0
    assert np.all(g[far] == 1.0) and np.all(N[far] == 0.0) and np.allclose(g[~far], g1[~far])
    with pytest.raises(ValueError, match="branches"):
        build_surface(np.array([[0, 0], [1, 0], [2, 0], [1, 1.0]]), np.array([[0, 1], [1, 2], [1, 3]]), flip=False)
    with pytest.raises(ValueError, match="degenerate"):
        build_surface(np.array([[0, 0], [0, 0.0]]), np.array([[0, 1]]), flip=False)


@pytest.mark.parametrize("dim", [2, 3])
def test_normal_derivative_is_the_normals_finite_difference(dim):
    """dN/dx (the static contact's curvature term at facet edges and vertices) against central differences of
    N at points outside a faceted circle / sphere, where the nearest point lies on edges and vertices as
    well as inside facets: equal to 1e-6 at every point whose nearest feature stays put over the difference."""
    if dim == 2:
        a = np.linspace(0, 2 * math.pi, 24, endpoint=False)
        V = 5.0 * np.stack([np.cos(a), np.sin(a)], axis=1)
        F = np.stack([np.arange(24), (np.arange(24) + 1) % 24], axis=1)
    else:
        V, F = icosphere(5.0, 1)
    s = build_surface(V, F, flip=False)
    rng = np.random.default_rng(2)
    x = rng.normal(size=(400, dim))
    x *= (rng.uniform(5.3, 7.0, 400) / np.linalg.norm(x, axis=1))[:, None]
    g, N, dN = surface_gaps(s, x, derivative=True)
    h = 1e-6
    fd = np.stack([(surface_gaps(s, x + h * e)[1] - surface_gaps(s, x - h * e)[1]) / (2 * h)
                   for e in np.eye(dim)], axis=2)
    err = np.abs(fd - dN).max(axis=(1, 2))
    turning = np.abs(dN).max(axis=(1, 2)) > 0
    assert turning.mean() > 0.1 and (~turning).mean() > 0.05        # edges/vertices and facet interiors both seen
    assert np.mean(err < 1e-6) > 0.97, np.sort(err)[-10:]
