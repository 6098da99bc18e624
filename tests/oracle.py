"""Shared by the oracle tests: rays around an object, and the agreement check."""
import numpy as np

from pcsg.trace.reference import Reference


def camera_rays(bounds, n, direction, spread=0.5, seed=0):
    """n*n rays from outside the box `bounds`, looking at its centre from `direction`,
    jittered so that no ray is special."""
    lo = np.where(np.isfinite(bounds[:3]), bounds[:3], -1.0)
    hi = np.where(np.isfinite(bounds[3:]), bounds[3:], 1.0)
    centre = (lo + hi) / 2
    radius = max(np.linalg.norm(hi - lo) / 2, 1e-3)
    direction = np.asarray(direction, float) / np.linalg.norm(direction)
    eye = centre + direction * radius * 3
    fwd = -direction
    up = np.array([0.0, 0.0, 1.0]) if abs(fwd[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    rng = np.random.default_rng(seed)
    u = (np.arange(n) + 0.5) / n * 2 - 1
    U, V = np.meshgrid(u, u)
    U = U.ravel() + rng.uniform(-0.4, 0.4, n * n) / n
    V = V.ravel() + rng.uniform(-0.4, 0.4, n * n) / n
    d = fwd + spread * (U[:, None] * right + V[:, None] * up)
    return np.tile(eye, (n * n, 1)), d


def assert_agrees(traced, origins, directions, min_hits=1, reference_graph=None):
    """The graph tracer and the brute-force reference (of its own graph, or of
    `reference_graph`) agree ray by ray."""
    ref = Reference(reference_graph or traced.graph).trace(origins, directions, exits=True)
    got = traced.trace(origins, directions)
    bad = np.nonzero(got.hit != ref["hit"])[0]
    assert len(bad) == 0, (f"{len(bad)} of {len(origins)} rays disagree on hit/miss, e.g. ray "
                           f"{bad[0]}: graph t={got.t[bad[0]]}, reference t={ref['t'][bad[0]]}")
    both = got.hit
    assert both.sum() >= min_hits
    rel = np.abs(got.t[both] - ref["t"][both]) / np.maximum(np.abs(ref["t"][both]), 1e-300)
    assert rel.max(initial=0) <= 1e-6, f"t differs by {rel.max()} (relative)"
    dn = np.abs(got.normal[both] - ref["normal"][both]).max(initial=0)
    assert dn <= 1e-4, f"normals differ by {dn}"
    # where surfaces of different paint coincide, which one shows is not specified
    sure = both & ~ref["tie"]
    gp, rp = got.paint[sure], ref["paint"][sure]
    assert np.array_equal(np.isnan(gp), np.isnan(rp))
    assert np.allclose(gp[~np.isnan(gp)], rp[~np.isnan(rp)], rtol=0, atol=1e-12)
    assert np.array_equal(got.material[sure], ref["material"][sure])
    return got
