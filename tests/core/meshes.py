"""Small synthetic meshes for the core tests (pure NumPy)."""

import numpy as np

from wrinkle_addon.core import mesh


def grid(nx=60, nz=40, width=0.14, height=0.08):
    """A flat forehead-like grid in the XZ plane, facing -Y, with quads, edges and triangles."""
    x, z = np.meshgrid(np.linspace(-width / 2, width / 2, nx), np.linspace(0.0, height, nz))
    rest = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], 1)
    idx = np.arange(nx * nz).reshape(nz, nx)
    quads = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(),
                      idx[1:, :-1].ravel()], 1)
    edges = np.concatenate([
        np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
        np.stack([idx[:-1, :].ravel(), idx[1:, :].ravel()], 1),
    ])
    tris = mesh.fan_triangles(quads.ravel(), np.arange(len(quads)) * 4, np.full(len(quads), 4))
    return rest, edges, tris, quads


def squash_vertical(rest, factor, top=0.08):
    """Compress the grid vertically toward its top edge (like raised brows)."""
    skin = rest.copy()
    skin[:, 2] = top - (top - skin[:, 2]) * factor
    return skin


def uv_grid(n):
    """An n x n vertex grid over the unit UV square: uv (V, 2), triangles (T, 3)."""
    c = np.linspace(0.0, 1.0, n)
    u, v = np.meshgrid(c, c)
    uv = np.stack([u.ravel(), v.ravel()], 1)
    idx = np.arange(n * n).reshape(n, n)
    quads = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(),
                      idx[1:, :-1].ravel()], 1)
    tris = mesh.fan_triangles(quads.ravel(), np.arange(len(quads)) * 4, np.full(len(quads), 4))
    return uv, tris
