"""core.refinement and the muscles' rule (core.muscles.resolution): the edge choice and
the smooth placement of new points."""

import numpy as np

from tests.core.meshes import grid
from wrinkle_addon.core import refinement
from wrinkle_addon.core.muscles import resolution
from wrinkle_addon.core.muscles.muscle import SHEET, Muscle


def sheet(**kw):
    params = dict(kind=SHEET, attachment=np.array([[-0.05, 0.0, 0.075], [0.05, 0.0, 0.075]]),
                  insertion=np.array([[-0.05, 0.0, 0.02], [0.05, 0.0, 0.02]]), length=0.07,
                  spread=0.12, spread_c=0.04, lambda_w=0.3, n_wrinkles=4, k0=0.001, alpha=1.0,
                  depth=0.02)
    params.update(kw)
    return Muscle(**params)


def _arc_pairs(h, count=200, seed=0):
    """Pairs of points on the unit sphere ``h`` radians apart, with their normals."""
    rng = np.random.default_rng(seed)
    p0 = rng.normal(size=(count, 3))
    p0 /= np.linalg.norm(p0, axis=1)[:, None]
    t = rng.normal(size=(count, 3))
    t -= (t * p0).sum(1)[:, None] * p0
    t /= np.linalg.norm(t, axis=1)[:, None]
    p1 = p0 * np.cos(h) + t * np.sin(h)
    points = np.concatenate([p0, p1])
    return points, np.stack([np.arange(count), np.arange(count, 2 * count)], 1)


def test_hermite_midpoints_lie_on_the_sphere_beyond_second_order():
    errors, flat = [], []
    for h in (0.2, 0.1, 0.05):
        p, pairs = _arc_pairs(h)
        mid = 0.5 * (p[pairs[:, 0]] + p[pairs[:, 1]])
        new = mid + refinement.hermite_offsets(p, p, pairs)  # unit sphere: normal = position
        errors.append(np.abs(np.linalg.norm(new, axis=1) - 1).max())
        flat.append(np.abs(np.linalg.norm(mid, axis=1) - 1).max())
    assert all(e < 0.02 * f for e, f in zip(errors, flat))
    # halving the edge divides the error by about 16 (fourth order), the facet's by 4
    assert errors[0] / errors[1] > 12 and errors[1] / errors[2] > 12


def test_hermite_midpoint_formula_and_plane_stays_planar():
    p = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    n = np.array([[0.0, 0, 1], [0.0, 0, 1]])
    assert np.array_equal(refinement.hermite_offsets(p, n, [[0, 1]]), np.zeros((1, 3)))
    n = np.array([[-0.6, 0, 0.8], [0.6, 0, 0.8]])  # a bump: the midpoint rises
    d = p[1] - p[0]
    t0, t1 = d - (d @ n[0]) * n[0], d - (d @ n[1]) * n[1]
    off = refinement.hermite_offsets(p, n, [[0, 1]])[0]
    assert np.allclose(off, (t0 - t1) / 8) and off[2] > 0
    rest, edges, _t, quads = grid(12, 8)
    split = np.arange(len(edges))
    normals = np.tile([0.0, -1.0, 0.0], (len(rest), 1))
    assert np.abs(refinement.hermite_offsets(rest, normals, edges[split])[:, 1]).max() == 0.0


def test_shape_key_stack_is_placed_from_each_keys_own_positions():
    p, pairs = _arc_pairs(0.1, count=20)
    stack = np.stack([p, 2.0 * p])  # the second "key": the sphere of radius 2
    off = refinement.hermite_offsets(stack, stack / np.linalg.norm(stack, axis=-1, keepdims=True), pairs)
    assert off.shape == (2, 20, 3)
    assert np.allclose(off[1], 2.0 * off[0])


def _split_grid(nx, nz):
    """A quad grid with every edge bisected as bmesh's grid fill does it: the new vertices
    are the edge midpoints, then one centre per quad, joined to its four midpoints."""
    rest, edges, _t, quads = grid(nx, nz)
    n, m = len(rest), len(edges)
    mid = {tuple(sorted(e)): n + i for i, e in enumerate(edges.tolist())}
    out = []
    for i, (a, b) in enumerate(edges.tolist()):
        out += [(a, n + i), (n + i, b)]
    for q, quad in enumerate(quads.tolist()):
        c = n + m + q
        for k in range(4):
            out.append((c, mid[tuple(sorted((quad[k], quad[(k + 1) % 4])))]))
    return rest, edges, quads, np.array(out)


def test_new_vertices_are_matched_to_their_edges_and_quad_centres():
    rest, edges, quads, after = _split_grid(5, 4)
    parent, centre, members, owner = refinement.new_vertex_parents(len(rest), after, edges)
    assert np.array_equal(parent[: len(edges)], np.arange(len(edges)))
    assert np.array_equal(centre, len(edges) + np.arange(len(quads)))
    assert np.array_equal(np.bincount(owner), np.full(len(quads), 4))
    # each centre's members are the four edges of its quad
    for q, quad in enumerate(quads.tolist()):
        ends = {tuple(sorted(edges[e])) for e in members[owner == q]}
        assert ends == {tuple(sorted((quad[k], quad[(k + 1) % 4]))) for k in range(4)}


def test_coons_centre_of_a_sphere_patch_lies_on_the_sphere():
    """A grid-quad centre goes to the facet centre plus twice the mean offset of its edge
    midpoints (bilinear Coons); on a sphere that is far closer than the flat centre."""
    a = 0.1
    corners = np.array([[-a, -a], [a, -a], [a, a], [-a, a]])
    p = np.c_[corners, np.sqrt(1.0 - (corners ** 2).sum(1))]  # on the unit sphere
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    offsets = refinement.hermite_offsets(p, p, pairs)
    centre = p.mean(0) + refinement.centre_offsets(offsets, np.arange(4), np.zeros(4, int), 1)[0]
    assert abs(np.linalg.norm(centre) - 1) < 0.03 * abs(np.linalg.norm(p.mean(0)) - 1)


def test_smooth_offsets_of_a_split_cylinder_grid_follow_the_cylinder():
    rest, edges, quads, after = _split_grid(9, 6)
    r = 0.05  # wrap the flat grid (x across) round a cylinder of radius r about the z axis
    ang = rest[:, 0] / r
    p = np.c_[r * np.sin(ang), -r * np.cos(ang), rest[:, 2]]
    normals = np.c_[np.sin(ang), -np.cos(ang), np.zeros(len(p))]
    off = refinement.smooth_offsets(p, normals, len(p), after, edges)
    flat_mid = 0.5 * (p[edges[:, 0]] + p[edges[:, 1]])
    flat_centre = np.stack([p[q].mean(0) for q in quads])
    new = np.concatenate([flat_mid, flat_centre]) + off
    radius = np.linalg.norm(new[:, :2], axis=1)
    flat_radius = np.linalg.norm(np.concatenate([flat_mid, flat_centre])[:, :2], axis=1)
    assert np.abs(radius - r).max() < 0.05 * np.abs(flat_radius - r).max()


def test_refine_edges_needs_amplitude_and_takes_only_what_breaks_the_rule():
    rest, edges, tris, quads = grid(30, 20)
    m = sheet()
    need = resolution.refine_edges(rest, edges, [m], factor=4)
    assert len(need)
    limit = resolution.edge_limits(rest, edges, [m], factor=4)
    length = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=1)
    assert np.array_equal(need, np.flatnonzero(length > limit))
    # no wrinkles (n_w = 0): the muscle still pulls, but no edge needs refining
    assert len(resolution.refine_edges(rest, edges, [sheet(n_wrinkles=0)], factor=4)) == 0
    # a coarser factor asks for less
    assert len(resolution.refine_edges(rest, edges, [m], factor=1)) < len(need)


def test_split_edges_on_quads_takes_exactly_the_needed_edges_and_counts_grids():
    rest, edges, _t, quads = grid(6, 5)
    corner = quads.ravel()
    starts, sizes = np.arange(len(quads)) * 4, np.full(len(quads), 4)
    split, grids = refinement.split_edges(rest, edges, corner, starts, sizes, np.arange(len(edges)))
    assert np.array_equal(split, np.arange(len(edges))) and grids == len(quads)
    split, grids = refinement.split_edges(rest, edges, corner, starts, sizes, [0])
    assert np.array_equal(split, [0]) and grids == 0


def test_split_edges_closes_triangles_over_their_longest_edge():
    # a thin triangle: splitting its short edge also bisects its long one
    rest = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.5, 0, 0.1]])
    edges = np.array([[0, 1], [1, 2], [2, 0]])
    split, _ = refinement.split_edges(rest, edges, [0, 1, 2], [0], [3], [1])
    assert np.array_equal(split, [0, 1])
