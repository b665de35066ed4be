#!/usr/bin/python3
"""An independent reference for the unknown-orientation accelerometer fit (means_table_test.cpp).

    ellipsoid_reference.py ROWS.csv G_MPS2 WEIGHTING

ROWS.csv: a header line, then per row the mean `ax,ay,az` [m/s^2] and its standard error per axis
`se_x,se_y,se_z` [m/s^2; relative weights when WEIGHTING is `relative`, ignored when `none`].
WEIGHTING: none | relative | absolute, as the fit weights the rows.

1. The algebraic ellipsoid fit of Li & Griffiths (2004), as Magneto does it: the quadric
   v^T [x^2, y^2, z^2, 2yz, 2xz, 2xy, 2x, 2y, 2z, 1] = 0 under the ellipsoid constraint 4J - I^2 = 1,
   the generalised eigenproblem of the 6x6 reduced scatter matrix; centre b and shape Q scaled so
   that (y - b)^T Q (y - b) = g^2 on the surface.
2. From there, Gauss-Newton on the cost the fit minimises, sum_k ((|R (y_k - b)| - g) / s_k)^2 with
   s_k = |y_k/|y_k| * se_k| (the standard error of |y_k| along the mean) and R upper triangular
   (Q = R^T R): a parameterisation of its own (the fit's is a lower-triangular scale and cross-axis
   form), the same minimiser in (b, Q). Its covariance: (J^T J)^-1, scaled by RSS/(n - p) (none,
   relative) or by max(1, RSS/(n - p)) (absolute); the standard errors of b and Q from it.

Prints one JSON object: b, Q, se_b, se_Q, sigma, iterations, and algebraic: {b, Q}.
"""
import json
import sys

import numpy as np


def algebraic_fit(y, g):
    x1, x2, x3 = y[:, 0], y[:, 1], y[:, 2]
    d = np.column_stack([x1**2, x2**2, x3**2, 2 * x2 * x3, 2 * x1 * x3, 2 * x1 * x2, 2 * x1, 2 * x2, 2 * x3,
                         np.ones(len(y))])
    s = d.T @ d
    s11, s12, s22 = s[:6, :6], s[:6, 6:], s[6:, 6:]
    k = 4.0
    c = np.zeros((6, 6))
    c[:3, :3] = k / 2 - 1
    np.fill_diagonal(c[:3, :3], -1.0)
    c[3, 3] = c[4, 4] = c[5, 5] = -k
    reduced = s11 - s12 @ np.linalg.solve(s22, s12.T)
    w, v = np.linalg.eig(np.linalg.solve(c, reduced))
    v1 = np.real(v[:, np.argmax(np.real(w))])
    v2 = -np.linalg.solve(s22, s12.T @ v1)
    a, b_, c_, f, g_, h = v1
    m = np.array([[a, h, g_], [h, b_, f], [g_, f, c_]])
    n = v2[:3]
    centre = -np.linalg.solve(m, n)
    scale = centre @ m @ centre - v2[3]
    q = m * g**2 / scale
    if np.linalg.eigvalsh(q).min() < 0:
        q = -q
    return centre, q


def unpack(p):
    b = p[:3]
    r = np.zeros((3, 3))
    r[np.triu_indices(3)] = p[3:]
    return b, r


def residuals_and_jacobian(p, y, g, s):
    b, r = unpack(p)
    d = y - b
    u = d @ r.T
    norm = np.linalg.norm(u, axis=1)
    res = (norm - g) / s
    jac = np.zeros((len(y), 9))
    uhat = u / norm[:, None]
    jac[:, :3] = -(uhat @ r) / s[:, None]
    for col, (i, j) in enumerate(zip(*np.triu_indices(3))):
        jac[:, 3 + col] = uhat[:, i] * d[:, j] / s
    return res, jac


def refine(y, g, s, b0, q0):
    p = np.concatenate([b0, np.linalg.cholesky(q0).T[np.triu_indices(3)]])
    cost = np.inf
    for it in range(1, 200):
        res, jac = residuals_and_jacobian(p, y, g, s)
        step = np.linalg.lstsq(jac, -res, rcond=None)[0]
        t = 1.0
        while t > 1e-6:
            new_res, _ = residuals_and_jacobian(p + t * step, y, g, s)
            if new_res @ new_res <= res @ res:
                break
            t /= 2
        p = p + t * step
        cost = new_res @ new_res
        if np.linalg.norm(t * step) <= 1e-15 * (1 + np.linalg.norm(p)):
            break
    res, jac = residuals_and_jacobian(p, y, g, s)
    return p, res, jac, it


def q_jacobian(r):
    """d vec(Q) / d (upper entries of R), Q = R^T R, over Q's 9 entries."""
    out = np.zeros((9, 6))
    idx = list(zip(*np.triu_indices(3)))
    for col, (a, bcol) in enumerate(idx):
        e = np.zeros((3, 3))
        e[a, bcol] = 1.0
        out[:, col] = (e.T @ r + r.T @ e).reshape(9)
    return out


def main():
    rows = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1, ndmin=2)
    g = float(sys.argv[2])
    weighting = sys.argv[3]
    y, se = rows[:, :3], rows[:, 3:6]
    s = np.ones(len(y)) if weighting == "none" else np.linalg.norm(y / np.linalg.norm(y, axis=1)[:, None] * se, axis=1)
    b0, q0 = algebraic_fit(y, g)
    p, res, jac, iterations = refine(y, g, s, b0, q0)
    b, r = unpack(p)
    dof = len(y) - 9
    chi2 = res @ res / dof if dof > 0 else 1.0
    factor = max(1.0, chi2) if weighting == "absolute" else chi2
    cov = np.linalg.inv(jac.T @ jac) * factor
    jq = q_jacobian(r)
    cov_q = jq @ cov[3:, 3:] @ jq.T
    print(json.dumps({
        "b": b.tolist(),
        "Q": (r.T @ r).tolist(),
        "se_b": np.sqrt(np.diag(cov[:3, :3])).tolist(),
        "se_Q": np.sqrt(np.maximum(np.diag(cov_q), 0)).reshape(3, 3).tolist(),
        "sigma": float(np.sqrt(res @ res / dof)) if dof > 0 else None,
        "iterations": iterations,
        "algebraic": {"b": b0.tolist(), "Q": q0.tolist()},
    }))


if __name__ == "__main__":
    main()
