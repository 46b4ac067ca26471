# SPDX-License-Identifier: GPL-3.0-or-later
"""Moving least squares ("Pattern functions and tears", §4.2, step four): the smoothing of a
shedding tear's noisy top surface.

At each query point ``x`` the weighted least-squares fit of degree ``r``::

    c(x) = argmin_c  sum_i w(|x - p_i|) (b(p_i) . c - f_i)^2
    f(x) = b(x) . c(x) = b(x)^T A(x)^-1 sum_i w(|x - p_i|) b(p_i) f_i,
    A(x) = sum_i w(|x - p_i|) b(p_i) b(p_i)^T

with ``b`` the monomials of total degree at most ``r`` in ``d`` dimensions
(``(d + r)! / (d! r!)`` of them) and the weight ``w(r) = 1 / (r^2 + eps^2)``: the text's
weight is garbled, but it says "setting the parameter to zero results in a singularity at
r = 0, which forces the MLS fit function to interpolate the data"; ``1 / (r^2 + eps^2)``
does exactly that (Levin's weight), and ``eps > 0`` smooths.  The fit reproduces every
polynomial of degree ``r`` exactly, whatever ``eps`` (tested).  Vectorised over the query
points in chunks; ``A`` is solved per query with ``numpy.linalg.solve`` on a stack.
"""

import math
from itertools import combinations_with_replacement

import numpy as np

from .. import checks

_CHUNK = 1 << 22  # query x data pairs (or query x monomial pairs) per chunk
MAX_DEGREE = 8
MAX_MONOMIALS = 100


def exponents(d, degree):
    """The exponents (m, d) of the monomials of total degree at most ``degree`` in ``d``
    variables, the constant first."""
    out = []
    for k in range(int(degree) + 1):
        for combo in combinations_with_replacement(range(d), k):
            e = np.zeros(d, np.int64)
            for axis in combo:
                e[axis] += 1
            out.append(e)
    return np.array(out, np.int64).reshape(-1, d)


def basis(points, exps):
    """The monomials ``b(p)`` (n, m) at ``points`` (n, d)."""
    p = np.asarray(points, np.float64)
    return np.prod(p[:, None, :] ** exps[None, :, :], axis=2)


def fit(points, values, queries, degree=1, eps=0.0, scale=None):
    """The MLS fit of ``values`` (n,) given at ``points`` (n, d), evaluated at ``queries``
    (q, d), with polynomials of total degree ``degree`` and the weight ``1 / (r^2 + eps^2)``
    (``eps`` in the points' units; 0 interpolates).  ``scale``: a length that normalises the
    coordinates (default: the points' extent), for a well-conditioned basis.  Raises
    ValueError when there are fewer points than monomials, for non-finite input, a degree
    that is not a whole number in 0..``MAX_DEGREE`` (or more than ``MAX_MONOMIALS``
    monomials) and a negative ``eps``."""
    p = checks.finite("The MLS points", points)
    p = p.reshape(len(p), -1)
    f = checks.finite("The MLS values", values).reshape(-1)
    q = checks.finite("The MLS queries", queries).reshape(-1, p.shape[1])
    d = p.shape[1]
    degree = checks.whole("The MLS degree", degree, 0, MAX_DEGREE)
    eps = checks.number("The MLS smoothing eps", eps, 0.0)
    if math.comb(d + degree, degree) > MAX_MONOMIALS:
        raise ValueError(f"A fit of degree {degree} in {d} dimensions has more than {MAX_MONOMIALS} "
                         "monomials")
    exps = exponents(d, degree)
    if len(p) < len(exps) or len(f) != len(p):
        raise ValueError(f"{len(p)} points and {len(f)} values for {len(exps)} monomials of degree {degree}")
    origin = p.mean(axis=0)
    if scale:
        s = checks.number("The MLS scale", scale, 0.0)
    else:
        with np.errstate(over="ignore"):  # an extent beyond the float range is refused below
            s = float(np.ptp(p, axis=0).max()) if len(p) else 1.0
        s = s or 1.0
    if not math.isfinite(s):
        raise ValueError("The MLS points spread beyond the range of floating-point numbers")
    with np.errstate(over="ignore", invalid="ignore"):
        pn, qn = (p - origin) / s, (q - origin) / s
        far = max(float(np.abs(pn).max(initial=0.0)), float(np.abs(qn).max(initial=0.0)))
    if not far <= 1e6:  # the basis would overflow (a monomial of degree 8 of 1e6 is 1e48)
        raise ValueError(f"The MLS scale {s:g} is too small for points and queries spread over "
                         f"{far * s:g}")
    # eps beyond a million extents weighs every point alike, as an infinite eps would
    e2 = min(eps / s, 1e6) ** 2
    bp = basis(pn, exps)  # (n, m)
    out = np.empty(len(q))
    step = max(1, _CHUNK // max(len(p), len(exps) ** 2, 1))
    for lo in range(0, len(q), step):
        x = qn[lo:lo + step]
        r2 = np.sum((x[:, None, :] - pn[None, :, :]) ** 2, axis=2)  # (c, n)
        exact = r2 + e2 <= 1e-30  # a query on a data point, eps = 0: the singular weight
        w = 1.0 / np.where(exact, 1.0, r2 + e2)
        w /= w.max(axis=1, keepdims=True)  # the same fit, and the 1e-14 below stays relative
        A = np.einsum("cn,nj,nk->cjk", w, bp, bp)
        rhs = np.einsum("cn,nj,n->cj", w, bp, f)
        coef = np.linalg.solve(A + 1e-14 * np.eye(len(exps))[None], rhs[..., None])[..., 0]
        val = np.einsum("cj,cj->c", basis(x, exps), coef)
        hit = exact.any(axis=1)
        if hit.any():  # interpolation: the data value itself
            val[hit] = f[np.argmax(exact[hit], axis=1)]
        out[lo:lo + step] = val
    return out
