"""Least squares of one shared pose and one depth per ring: Levenberg-Marquardt for an arrow-shaped Jacobian.

In the pose fit (``ring_fit._fit``) every residual depends on the few pose
parameters, and a ring point's two residuals on its own ring's depth only.
The normal equations are then a small dense pose block bordered by a
diagonal depth block; this fit builds them with bincounts from the
Jacobian's pose columns and each point's derivative along its own depth
(``PipeView.reproject_jacobian`` gives both exactly), with no sparse
matrices and no finite differences. For the soft-L1 loss the gradient
weights each residual by rho' and the Hessian by rho' + 2 z rho'' (the
second-order correction ``scipy.optimize.least_squares`` also applies), so
both reach the same stationary points; the stopping tolerances are that
function's defaults.

Cost: C(x) = 1/2 sum rho(f_i(x)^2) with rho(z) = z ("linear") or
rho(z) = 2 (sqrt(1 + z) - 1) ("soft_l1").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ArrowFit", "fit_pose_and_depths"]

FTOL = 1e-8         # relative decrease of the cost that ends the fit
XTOL = 1e-8         # relative step that ends the fit
MAX_ITERATIONS = 100


@dataclass(frozen=True)
class ArrowFit:
    """x : parameters at the solution (pose first, then depths); fun : residuals there (M,); jac : the Jacobian
    there (M, N), dense; nfev : evaluations of the residuals."""

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    nfev: int


def _weights(f: np.ndarray, loss: str) -> tuple[np.ndarray, np.ndarray]:
    """Weights of the residuals in the gradient, rho'(z), and in the Gauss-Newton Hessian, rho'(z) + 2 z rho''(z)
    (z = f^2): for soft_l1 (1 + z)^-1/2 and (1 + z)^-3/2, which keeps the Newton step of the robust cost."""
    if loss == "linear":
        one = np.ones_like(f)
        return one, one
    w = 1.0 / np.sqrt(1.0 + f * f)
    return w, w ** 3


def _cost(f: np.ndarray, loss: str) -> float:
    z = f * f
    return 0.5 * float(np.sum(z if loss == "linear" else 2.0 * (np.sqrt(1.0 + z) - 1.0)))


def fit_pose_and_depths(residuals, x0, n_pose: int, ring_of_point: np.ndarray, *, loss: str = "linear") -> ArrowFit:
    """Minimise the cost of the residuals over x = (pose (n_pose,), one depth per ring).

    residuals : (x, jacobian: bool) -> f (M,), or (f, pose columns (M,
        n_pose), along (2 m,)) with the Jacobian: f holds the m points' (x, y)
        residuals in pairs, then rows that depend on the pose only (priors);
        ``along`` is each point row's derivative along its own ring's depth;
    ring_of_point : (m,) ring index of each point, 0 .. len(x0) - n_pose - 1;
    loss : "linear" or "soft_l1" (f_scale 1).
    """
    x = np.asarray(x0, float).copy()
    n_rings = len(x) - n_pose
    rows = np.repeat(np.asarray(ring_of_point), 2)
    m2 = len(rows)
    nfev = 1
    f, pose_cols, along = residuals(x, True)
    cost = _cost(f, loss)
    lam = 1e-3
    for _ in range(MAX_ITERATIONS):
        w, h = _weights(f, loss)
        wp = pose_cols * h[:, None]
        wa = h[:m2] * along
        A = np.zeros((len(x), len(x)))
        A[:n_pose, :n_pose] = pose_cols.T @ wp
        for j in range(n_pose):
            A[j, n_pose:] = np.bincount(rows, wa * pose_cols[:m2, j], n_rings)
        A[n_pose:, :n_pose] = A[:n_pose, n_pose:].T
        A[np.arange(n_pose, len(x)), np.arange(n_pose, len(x))] = np.bincount(rows, wa * along, n_rings)
        wf = w * f
        g = np.concatenate([pose_cols.T @ wf, np.bincount(rows, along * wf[:m2], n_rings)])
        diag = np.diag(A).copy()
        scale = np.maximum(diag, 1e-12 * max(float(diag.max()), 1e-300))
        while True:
            try:
                step = np.linalg.solve(A + lam * np.diag(scale), -g)
            except np.linalg.LinAlgError:
                step = None
            if step is not None and np.all(np.isfinite(step)):
                nfev += 1
                f_new = residuals(x + step, False)
                cost_new = _cost(f_new, loss)
                if cost_new < cost:
                    break
            lam *= 4.0
            if lam > 1e12:          # no step lowers the cost: x is the minimum to working precision
                return _result(x, f, pose_cols, along, rows, n_pose, nfev)
        x = x + step
        converged = (np.linalg.norm(step) < XTOL * (XTOL + np.linalg.norm(x))) or (cost - cost_new < FTOL * cost)
        cost, lam = cost_new, max(lam / 3.0, 1e-12)
        nfev += 1
        f, pose_cols, along = residuals(x, True)
        if converged:
            break
    return _result(x, f, pose_cols, along, rows, n_pose, nfev)


def _result(x, f, pose_cols, along, rows, n_pose, nfev) -> ArrowFit:
    J = np.zeros((len(f), len(x)))
    J[:, :n_pose] = pose_cols
    J[np.arange(len(rows)), n_pose + rows] = along
    return ArrowFit(x, f, J, nfev)
