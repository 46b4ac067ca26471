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

from itertools import combinations_with_replacement

import numpy as np

_CHUNK = 1 << 22  # query x data pairs per chunk


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
    ValueError when there are fewer points than monomials."""
    p = np.asarray(points, np.float64)
    p = p.reshape(len(p), -1)
    f = np.asarray(values, np.float64).reshape(-1)
    q = np.asarray(queries, np.float64).reshape(-1, p.shape[1])
    d = p.shape[1]
    exps = exponents(d, degree)
    if len(p) < len(exps) or len(f) != len(p):
        raise ValueError(f"{len(p)} points and {len(f)} values for {len(exps)} monomials of degree {degree}")
    origin = p.mean(axis=0)
    s = float(scale) if scale else float(np.ptp(p, axis=0).max()) or 1.0
    pn, qn = (p - origin) / s, (q - origin) / s
    e2 = (float(eps) / s) ** 2
    bp = basis(pn, exps)  # (n, m)
    out = np.empty(len(q))
    step = max(1, _CHUNK // max(len(p), 1))
    for lo in range(0, len(q), step):
        x = qn[lo:lo + step]
        r2 = np.sum((x[:, None, :] - pn[None, :, :]) ** 2, axis=2)  # (c, n)
        exact = r2 + e2 <= 1e-30  # a query on a data point, eps = 0: the singular weight
        w = 1.0 / np.where(exact, 1.0, r2 + e2)
        A = np.einsum("cn,nj,nk->cjk", w, bp, bp)
        rhs = np.einsum("cn,nj,n->cj", w, bp, f)
        coef = np.linalg.solve(A + 1e-14 * np.eye(len(exps))[None], rhs[..., None])[..., 0]
        val = np.einsum("cj,cj->c", basis(x, exps), coef)
        hit = exact.any(axis=1)
        if hit.any():  # interpolation: the data value itself
            val[hit] = f[np.argmax(exact[hit], axis=1)]
        out[lo:lo + step] = val
    return out
