"""Direction fields, stroke constraints and shrinkage on the mapped mesh (Bando et al. 2002,
§4, §5.1, §7): analytic cases on flat grids mapped with ``uv = xy``."""

import warnings

import numpy as np
import pytest

from wrinkle_addon.core.bando import field


def grid(n=21, m=None, size=1.0):
    """A flat (n x m) vertex grid on [0, size]^2, right triangles (each quad split along
    the same diagonal), ``uv = xy`` and ``rest = (x, y, 0)``."""
    m = n if m is None else m
    x, y = np.meshgrid(np.linspace(0.0, size, n), np.linspace(0.0, size, m))
    uv = np.stack([x.ravel(), y.ravel()], 1)
    idx = np.arange(n * m).reshape(m, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    rest = np.concatenate([uv, np.zeros((len(uv), 1))], 1)
    return uv, tris, rest


def lattice(n=15, jitter=0.0, seed=0):
    """A triangular lattice (near-equilateral triangles) with optional interior jitter in
    units of the spacing: a Delaunay-like mesh with all angles acute."""
    rng = np.random.default_rng(seed)
    h = 1.0 / (n - 1)
    j, i = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    uv = np.stack([(i + 0.5 * (j % 2)) * h, j * h * np.sqrt(3) / 2], -1).reshape(-1, 2)
    idx = np.arange(n * n).reshape(n, n)
    tris = []
    for r in range(n - 1):  # builds the test mesh, rows of the lattice
        a, b, c, d = idx[r, :-1], idx[r, 1:], idx[r + 1, :-1], idx[r + 1, 1:]
        if r % 2 == 0:
            tris += [np.stack([a, b, c], 1), np.stack([b, d, c], 1)]
        else:
            tris += [np.stack([a, d, c], 1), np.stack([a, b, d], 1)]
    tris = np.concatenate(tris)
    interior = ~np.isin(np.arange(n * n), np.concatenate([idx[0], idx[-1], idx[:, 0], idx[:, -1]]))
    uv[interior] += rng.uniform(-jitter, jitter, (interior.sum(), 2)) * h
    return uv, tris, interior


def boundary(n, m=None):
    m = n if m is None else m
    idx = np.arange(n * m).reshape(m, n)
    return np.unique(np.concatenate([idx[0], idx[-1], idx[:, 0], idx[:, -1]]))


# --------------------------------------------------------------------------- interpolation
def test_grid_weights_are_the_five_point_laplacian_and_reproduce_linear_data():
    uv, tris, rest = grid(21)
    lap = field.spring_laplacian(rest, tris)
    d = np.abs(uv[lap.edges[:, 1]] - uv[lap.edges[:, 0]])
    axis = (d < 1e-12).any(axis=1)
    ends = uv[lap.edges]  # (E, 2, 2)
    rim = np.any(np.all((ends < 1e-12) | (ends > 1 - 1e-12), axis=1), axis=1)  # both ends on one side
    np.testing.assert_allclose(lap.weights[axis & ~rim], 1.0, atol=1e-12)  # (cot 45 + cot 45) / 2
    np.testing.assert_allclose(lap.weights[axis & rim], 0.5, atol=1e-12)  # one triangle
    np.testing.assert_allclose(lap.weights[~axis], field.MIN_WEIGHT)  # cot 90: clamped
    fixed = boundary(21)
    linear = np.stack([0.3 + 2.0 * uv[:, 0] - 1.5 * uv[:, 1], -uv[:, 0] + 0.25 * uv[:, 1]], 1)
    got = field.interpolate(rest, tris, fixed, linear[fixed])
    assert got.dtype == np.float64 and got.shape == (len(uv), 2)
    np.testing.assert_allclose(got, linear, atol=1e-8, rtol=0)
    # a non-linear boundary gives a smooth, non-trivial interior within its bounds
    bumpy = np.sin(3 * uv[:, 0]) * uv[:, 1]
    got = field.interpolate(rest, tris, fixed, bumpy[fixed], laplacian=lap)
    assert got.shape == (len(uv),)
    assert bumpy[fixed].min() - 1e-12 <= got.min() and got.max() <= bumpy[fixed].max() + 1e-12
    assert np.abs(got - linear[:, 0]).max() > 0.1


def test_jittered_lattice_in_3d_reproduces_linear_data():
    uv, tris, _interior = lattice(15, jitter=0.15, seed=1)
    angle = 0.7  # the plane tilted in space: the weights come from the 3-D triangles
    frame = np.array([[1.0, 0.0], [0.0, np.cos(angle)], [0.0, np.sin(angle)]])
    rest = uv @ frame.T + np.array([0.2, -0.1, 0.5])
    lap = field.spring_laplacian(rest, tris)
    assert lap.weights.min() > field.MIN_WEIGHT  # every weight positive: no clamping
    fixed = boundary(15)
    linear = 1.0 - 0.7 * uv[:, 0] + 3.0 * uv[:, 1]
    got = field.interpolate(rest, tris, fixed, linear[fixed])
    np.testing.assert_allclose(got, linear, atol=1e-8, rtol=0)
    # uniform weights would not reproduce it: the cotangent weights matter
    flat = field.SpringLaplacian(lap.n, lap.edges, np.ones_like(lap.weights), np.bincount(
        lap.edges.ravel(), minlength=lap.n).astype(float), lap.component)
    assert np.abs(field.interpolate(rest, tris, fixed, linear[fixed], laplacian=flat) - linear).max() > 1e-4


def test_unconstrained_component_gets_zero_and_held_values_stay():
    uv, tris, rest = grid(6)
    n = len(uv)
    uv2 = np.concatenate([uv, uv + [2.0, 0.0]])  # a second island, disconnected
    tris2 = np.concatenate([tris, tris + n])
    rest2 = np.concatenate([rest, rest + [2.0, 0.0, 0.0]])
    isolated = len(uv2)  # and a vertex in no triangle
    rest2 = np.concatenate([rest2, [[5.0, 5.0, 0.0]]])
    fixed = np.array([0, 7, 20, 35])
    values = np.array([[1.0, -2.0], [0.5, 3.0], [-1.0, 0.25], [2.0, 2.0]])
    got = field.interpolate(rest2, tris2, fixed, values)
    np.testing.assert_array_equal(got[fixed], values)
    assert np.all(got[n:] == 0.0)
    assert got[isolated].tolist() == [0.0, 0.0]
    free = np.setdiff1d(np.arange(n), fixed)
    assert np.all(np.isfinite(got)) and np.all(np.abs(got[free]).sum(axis=1) > 0)
    again = field.interpolate(rest2, tris2, fixed, values)
    np.testing.assert_array_equal(got, again)  # deterministic
    # a first guess (say the previous result) changes nothing but the work
    warm = field.interpolate(rest2, tris2, fixed, values, initial=got + 0.01, max_iterations=200)
    np.testing.assert_allclose(warm, got, atol=1e-9)
    short = field.interpolate(rest2, tris2, fixed, values, initial=got, max_iterations=0)
    np.testing.assert_array_equal(short[:n], got[:n])
    assert np.all(short[n:] == 0.0)  # even a guess there is ignored
    with pytest.raises(ValueError):
        field.interpolate(rest2, tris2, fixed, values, initial=got[:, :1])


@pytest.mark.parametrize("case", ["empty", "nan", "shape", "range", "twice", "tris"])
def test_interpolate_rejects_bad_input(case):
    _uv, tris, rest = grid(5)
    fixed, values = np.array([0, 24]), np.array([0.0, 1.0])
    if case == "empty":
        fixed, values = np.zeros(0, int), np.zeros(0)
    elif case == "nan":
        values = np.array([0.0, np.nan])
    elif case == "shape":
        values = np.zeros(3)
    elif case == "range":
        fixed = np.array([0, 25])
    elif case == "twice":
        fixed = np.array([3, 3])
    else:
        tris = tris[:, :2]
    with pytest.raises(ValueError):
        field.interpolate(rest, tris, fixed, values)
    with pytest.raises(ValueError):
        field.interpolate(np.where(np.arange(25)[:, None] == 3, np.nan, rest), tris[:, :3] if case != "tris"
                          else tris, [0], [1.0])


# --------------------------------------------------------------------------- direction fields
def test_direction_field_interpolates_and_clips_magnitudes():
    uv, tris, rest = grid(11)
    fixed = np.array([0, 120])  # opposite corners
    got = field.direction_field(rest, uv, tris, fixed, np.array([[3.0, 0.0], [0.0, 0.5]]))
    assert got.shape == (121, 2)
    np.testing.assert_allclose(got[0], [1.0, 0.0])  # a held vector longer than 1 is clipped
    np.testing.assert_allclose(got[120], [0.0, 0.5])
    assert np.linalg.norm(got, axis=1).max() <= 1.0 + 1e-12
    assert np.all(got >= -1e-12) and got[60, 0] > 0 and got[60, 1] > 0  # a blend in between
    # opposite vectors cancel (the documented caveat of component-wise interpolation)
    cancel = field.direction_field(rest, uv, tris, fixed, np.array([[1.0, 0.0], [-1.0, 0.0]]))
    assert np.linalg.norm(cancel[60]) < 1e-6
    with pytest.raises(ValueError):
        field.direction_field(rest, uv[:-1], tris, fixed, np.ones((2, 2)))
    with pytest.raises(ValueError):
        field.direction_field(rest, uv, tris, fixed, np.ones((2, 3)))


def test_rotate_by_90_degrees_gives_perpendicular_vectors_of_the_same_length():
    rng = np.random.default_rng(2)
    f = rng.normal(size=(50, 2))
    r = field.rotate(f, np.pi / 2)
    np.testing.assert_allclose(np.einsum("ij,ij->i", f, r), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), np.linalg.norm(f, axis=1))
    np.testing.assert_allclose(r, np.stack([-f[:, 1], f[:, 0]], 1), atol=1e-12)  # counter-clockwise
    per_vertex = field.rotate(f, np.linspace(0, np.pi, 50))
    np.testing.assert_allclose(per_vertex[0], f[0])
    np.testing.assert_allclose(per_vertex[-1], -f[-1], atol=1e-12)
    with pytest.raises(ValueError):
        field.rotate(f, np.zeros(3))


def test_straight_stroke_constrains_the_vertices_along_it():
    uv, tris, _rest = grid(21)  # spacing 0.05
    stroke = np.array([[0.1, 0.5], [0.4, 0.5], [0.7, 0.5]])  # along the row y = 0.5
    fixed, vectors = field.stroke_constraints(uv, tris, [stroke], reference_length=1.2)
    np.testing.assert_allclose(uv[fixed, 1], 0.5)
    np.testing.assert_allclose(np.sort(uv[fixed, 0]), np.linspace(0.1, 0.7, 13), atol=1e-12)
    np.testing.assert_allclose(vectors, np.tile([0.5, 0.0], (13, 1)), atol=1e-12)  # m = 0.6 / 1.2
    assert np.all(np.diff(fixed) > 0)
    # m proportional to the length, capped at 1; the tangent follows the stroke
    diagonal = np.array([[0.2, 0.2], [0.5, 0.5]])
    for ref, m in ((np.sqrt(0.18) * 4, 0.25), (np.sqrt(0.18) * 2, 0.5), (0.1, 1.0)):
        fixed, vectors = field.stroke_constraints(uv, tris, [diagonal[::-1]], reference_length=ref)
        np.testing.assert_allclose(uv[fixed, 0], uv[fixed, 1], atol=1e-12)
        assert len(fixed) == 7
        np.testing.assert_allclose(vectors, np.tile(-m * np.sqrt(0.5) * np.ones(2), (7, 1)), atol=1e-12)
    # a stroke off the mesh constrains nothing; bad strokes are refused
    fixed, vectors = field.stroke_constraints(uv, tris, [np.array([[2.0, 2.0], [3.0, 2.0]])], 1.0)
    assert fixed.shape == (0,) and vectors.shape == (0, 2)
    point, still = np.array([[0.1, 0.1]]), np.array([[0.1, 0.1], [0.1, 0.1]])
    for bad in ([point], [still], [np.array([[0, np.nan], [1, 1]])]):
        with pytest.raises(ValueError):
            field.stroke_constraints(uv, tris, bad, 1.0)
    with pytest.raises(ValueError):
        field.stroke_constraints(uv, tris, [stroke], 0.0)


def test_crossing_strokes_average_at_the_shared_vertex():
    uv, tris, _rest = grid(21)
    a = np.array([[0.2, 0.5], [0.8, 0.5]])
    b = np.array([[0.5, 0.2], [0.5, 0.8]])
    fixed, vectors = field.stroke_constraints(uv, tris, [a, b], reference_length=0.6)
    centre = np.flatnonzero((np.abs(uv[fixed] - 0.5) < 1e-9).all(axis=1))
    assert len(centre) == 1
    assert vectors[centre[0]][0] > 0.2 and vectors[centre[0]][1] > 0.2
    others = np.delete(vectors, centre, axis=0)
    np.testing.assert_allclose(np.linalg.norm(others, axis=1), 1.0)


# --------------------------------------------------------------------------- from the poses
def test_deformation_field_runs_across_the_compression():
    uv, tris, rest = grid(11)
    squeezed = rest * [0.9, 1.0, 1.0]  # compressed along x by 10 %
    f = field.deformation_field(rest, [squeezed], uv, tris)
    m = np.linalg.norm(f, axis=1)
    np.testing.assert_allclose(m, 0.1 / field.C_REF, atol=1e-9)
    assert np.all(np.abs(f[:, 1]) / m > 0.99)  # wrinkles along y
    still = field.deformation_field(rest, [rest + [0.3, -0.2, 1.0]], uv, tris)
    assert np.all(still == 0.0)
    stretched = field.deformation_field(rest, [rest * [1.3, 1.0, 1.0]], uv, tris)
    assert np.all(stretched == 0.0)  # stretching never wrinkles
    # a stronger pose along y wins over a weaker one along x; weights move the balance
    up = rest * [1.0, 0.7, 1.0]
    both = field.deformation_field(rest, [squeezed, up], uv, tris)
    assert np.all(np.abs(both[:, 0]) > 0.99 * np.linalg.norm(both, axis=1))
    tilted = field.deformation_field(rest, [squeezed, up], uv, tris, weights=[1.0, 0.01])
    assert np.all(np.abs(tilted[:, 1]) > 0.99 * np.linalg.norm(tilted, axis=1))
    # the UV layout's scale and the 3-D placement do not matter, and signs agree
    rot = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    moved = field.deformation_field(rest @ rot.T, [squeezed @ rot.T], uv * 0.3, tris)
    np.testing.assert_allclose(moved, f, atol=1e-9)
    assert np.all(f[:, 1] * f[0, 1] > 0)
    with pytest.raises(ValueError):
        field.deformation_field(rest, [], uv, tris)
    with pytest.raises(ValueError):
        field.deformation_field(rest, [squeezed[:-1]], uv, tris)


def test_deformation_field_follows_a_sheared_compression():
    uv, tris, rest = grid(9)
    angle = np.radians(30)
    c = np.array([np.cos(angle), np.sin(angle)])  # compressed by 20 % along 30 degrees
    strain = np.eye(2) - 0.2 * np.outer(c, c)
    pose = np.concatenate([uv @ strain.T, np.zeros((len(uv), 1))], 1)
    f = field.deformation_field(rest, [pose], uv, tris)
    m = np.linalg.norm(f, axis=1)
    np.testing.assert_allclose(m, 1.0)  # 0.2 > c_ref: capped
    np.testing.assert_allclose(np.abs(f @ c), 0.0, atol=1e-9)  # perpendicular to it


def test_deformation_field_fill_gives_the_weak_skin_the_strong_orientation():
    uv, tris, rest = grid(11)
    x = rest[:, 0]
    pose = rest.copy()
    pose[:, 0] = np.where(x < 0.5, 0.8 * x, x - 0.1)  # the left half squeezed along x
    raw = field.deformation_field(rest, [pose], uv, tris)
    right = x > 0.55
    assert np.all(raw[right] == 0.0) and np.all(np.abs(raw[x < 0.45, 1]) > 0.99)
    filled = field.deformation_field(rest, [pose], uv, tris, fill_threshold=0.5, floor=0.2)
    np.testing.assert_allclose(np.abs(filled[right]), np.tile([0.0, 0.2], (right.sum(), 1)), atol=1e-9)
    np.testing.assert_allclose(filled[x < 0.45], raw[x < 0.45], atol=1e-12)


# --------------------------------------------------------------------------- modulation
@pytest.mark.parametrize("r", [0.2, 0.5, 0.8])
def test_modulation_is_c1_at_zero(r):
    h = 1e-6
    m0, mp, mn = (float(field.modulation(s, r)) for s in (0.0, h, -h))
    assert m0 == pytest.approx(r, abs=1e-15)
    assert (mp - m0) / h == pytest.approx(1 - r, rel=1e-5)
    assert (m0 - mn) / h == pytest.approx(1 - r, rel=1e-5)  # r (1/r - 1) = 1 - r
    assert float(field.modulation(1.0, r)) == pytest.approx(1.0)
    assert float(field.modulation(5.0, r)) == pytest.approx(1.0)  # s clipped to 1
    s = np.linspace(-3, 1, 41)
    assert np.all(np.diff(field.modulation(s, r)) > 0)


def test_modulation_limits_without_warnings():
    s = np.array([-50.0, -1.0, -1e-9, 0.0, 0.5, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        zero = field.modulation(s, 0.0)
        one = field.modulation(s, 1.0)
        tiny = field.modulation(s, 1e-300)
    np.testing.assert_array_equal(zero, [0.0, 0.0, 0.0, 0.0, 0.5, 1.0])
    np.testing.assert_array_equal(one, [1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    assert np.all(np.isfinite(tiny))
    np.testing.assert_allclose(field.modulation(s, np.array([0.5])), field.modulation(s, 0.5))
    for bad in ((s, 1.5), (s, -0.1), (np.array([np.nan]), 0.5)):
        with pytest.raises(ValueError):
            field.modulation(*bad)


# --------------------------------------------------------------------------- shrinkage
def _pose(uv, matrix):
    return np.concatenate([uv @ np.asarray(matrix, float).T, np.zeros((len(uv), 1))], 1)


def _interior(uv, margin=1e-9):
    return np.all((uv > margin) & (uv < 1 - margin), axis=1)


@pytest.mark.parametrize("k", [0.3, 0.6, 0.95])
def test_compression_across_the_wrinkle_gives_one_minus_k(k):
    uv, tris, rest = grid(11)
    for direction, across in (([1.0, 0.0], np.diag([1.0, k])), ([0.0, 2.0], np.diag([k, 1.0]))):
        plan = field.shrinkage_plan(uv, tris, np.tile(direction, (len(uv), 1)), rest)
        s = field.shrinkage(plan, _pose(uv, across))
        np.testing.assert_allclose(s, 1 - k, atol=1e-9)  # every vertex, boundary ones too
        along = np.diag([k, 1.0]) if direction[0] else np.diag([1.0, k])
        np.testing.assert_allclose(field.shrinkage(plan, _pose(uv, along)), 0.0, atol=1e-9)
        np.testing.assert_allclose(field.shrinkage(plan, rest), 0.0, atol=1e-12)


def test_stretch_across_the_wrinkle_is_negative():
    uv, tris, rest = grid(11)
    plan = field.shrinkage_plan(uv, tris, np.tile([1.0, 0.0], (len(uv), 1)), rest)
    s = field.shrinkage(plan, _pose(uv, np.diag([1.0, 1.4])))
    np.testing.assert_allclose(s, -0.4, atol=1e-9)


def test_the_two_sides_are_averaged_and_a_boundary_vertex_uses_its_one_side():
    uv, tris, rest = grid(11)
    plan = field.shrinkage_plan(uv, tris, np.tile([1.0, 0.0], (len(uv), 1)), rest)
    sides = np.bincount(plan.vertex, minlength=len(uv))
    on_edge = (np.abs(uv[:, 1]) < 1e-12) | (np.abs(uv[:, 1] - 1) < 1e-12)  # d_p = +-y leaves here
    np.testing.assert_array_equal(sides, np.where(on_edge, 1, 2))
    assert set(np.unique(plan.side)) == {-1, 1}
    np.testing.assert_allclose(plan.alpha + plan.beta, 10.0)  # L = 1/(alpha + beta) = spacing
    # the upper half squeezed across by 0.5: the middle row averages 0.5 and 0
    y = uv[:, 1]
    pose = rest.copy()
    pose[:, 1] = np.where(y <= 0.5, y, 0.5 + 0.5 * (y - 0.5))
    s = field.shrinkage(plan, pose)
    middle = np.abs(y - 0.5) < 1e-9
    np.testing.assert_allclose(s[middle], 0.25, atol=1e-9)
    np.testing.assert_allclose(s[y > 0.55], 0.5, atol=1e-9)
    np.testing.assert_allclose(s[y < 0.45], 0.0, atol=1e-9)


def _reference_shrinkage(uv, tris, direction, rest, pose, v):
    """Eq. 4 at one vertex, the direct way: loop over its triangles and solve for alpha,
    beta with a 2x2 solve."""
    d = direction[v] / np.linalg.norm(direction[v])
    dp = np.array([-d[1], d[0]])
    values = []
    for sign in (1.0, -1.0):
        for tri in tris[(tris == v).any(axis=1)]:
            k = int(np.flatnonzero(tri == v)[0])
            v2, v3 = tri[(k + 1) % 3], tri[(k + 2) % 3]
            a, b = uv[v2] - uv[v], uv[v3] - uv[v]
            alpha, beta = np.linalg.solve(np.stack([a, b], 1), sign * dp)
            if alpha >= 0 and beta >= 0:
                t2 = np.linalg.norm(pose[v2] - pose[v]) / np.linalg.norm(rest[v2] - rest[v])
                t3 = np.linalg.norm(pose[v3] - pose[v]) / np.linalg.norm(rest[v3] - rest[v])
                values.append(1 - (alpha + beta) / (alpha / t2 + beta / t3))
                break
    return np.mean(values)


def test_rotated_direction_and_anisotropic_scaling_match_the_formula():
    uv, tris, rest = grid(9)
    angle = np.radians(30)
    direction = np.tile([np.cos(angle), np.sin(angle)], (len(uv), 1))
    plan = field.shrinkage_plan(uv, tris, direction, rest)
    matrix = np.array([[0.7, 0.15], [0.0, 1.2]])
    pose = _pose(uv, matrix)
    s = field.shrinkage(plan, pose)
    inner = np.flatnonzero(_interior(uv))
    want = np.array([_reference_shrinkage(uv, tris, direction, rest, pose, v) for v in inner])
    np.testing.assert_allclose(s[inner], want, atol=1e-9)
    assert np.ptp(want) < 1e-9 and abs(want[0]) > 0.02  # the same wedge shapes everywhere


def test_jittered_mesh_under_isotropic_scaling_gives_one_minus_k():
    uv, tris, _interior_mask = lattice(13, jitter=0.3, seed=4)
    rng = np.random.default_rng(5)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rest = np.concatenate([uv, np.zeros((len(uv), 1))], 1) @ q.T  # any placement in space
    direction = rng.normal(size=(len(uv), 2))
    plan = field.shrinkage_plan(uv, tris, direction, rest)
    covered = np.isin(np.arange(len(uv)), plan.vertex)  # lattice corners may miss both +-d_p
    assert covered.sum() > len(uv) - 8
    for k in (0.5, 0.8, 1.25):
        pose = rest @ q * k @ q.T @ q.T + [0.1, 0.2, 0.3]  # scaled by k, moved and turned
        s = field.shrinkage(plan, pose)
        np.testing.assert_allclose(s[covered], 1 - k, atol=1e-9)
        assert np.all(s[~covered] == 0.0)
        s32 = field.shrinkage(plan, pose.astype(np.float32))
        assert s32.dtype == np.float32
        np.testing.assert_allclose(s32[covered], 1 - k, atol=1e-5)


def test_shrinkage_edge_cases():
    uv, tris, rest = grid(6)
    direction = np.tile([1.0, 0.0], (len(uv), 1))
    direction[7] = 0.0  # no wrinkle here
    plan = field.shrinkage_plan(uv, tris, direction, rest)
    pose = _pose(uv, np.diag([1.0, 0.5]))
    s = field.shrinkage(plan, pose)
    assert s[7] == 0.0 and np.all(np.delete(s, 7) > 0.49)
    collapsed = pose.copy()
    collapsed[13] = collapsed[19]  # the edge above 13 (+d_p) has zero length: that side's s is 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = field.shrinkage(plan, collapsed)
    assert np.all(np.isfinite(s)) and np.all(s <= 1.0 + 1e-12)
    assert s[13] == pytest.approx(0.5) and s[19] == pytest.approx(0.75)  # (1 + 0) / 2, (1 + 0.5) / 2
    # a vertex in no triangle has no corner: s = 0
    extra = np.concatenate([direction, [[1.0, 0.0]]])
    far_uv, far_rest = np.concatenate([uv, [[3.0, 3.0]]]), np.concatenate([rest, [[3, 3, 0]]])
    plan = field.shrinkage_plan(far_uv, tris, extra, far_rest)
    assert field.shrinkage(plan, np.concatenate([pose, [[9.0, 9.0, 9.0]]]))[-1] == 0.0
    with pytest.raises(ValueError):
        field.shrinkage(plan, pose)  # one vertex short
    bad = np.concatenate([pose, [[9.0, 9.0, 9.0]]])
    bad[3, 1] = np.nan
    with pytest.raises(ValueError):
        field.shrinkage(plan, bad)
    with pytest.raises(ValueError):
        field.shrinkage_plan(uv, tris, direction[:-1], rest)
    with pytest.raises(ValueError):
        field.shrinkage_plan(uv, tris, np.where(direction == 1.0, np.nan, direction), rest)
