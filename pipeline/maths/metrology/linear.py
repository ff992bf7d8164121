"""Law of propagation of uncertainty (JCGM 100:2008, the GUM).

The estimate is the model at the input estimates (GUM 4.1.4), the combined
standard uncertainty follows GUM eq. (13), u_c^2 = c^T V c with the
sensitivity coefficients c_i = df/dx_i (GUM 5.1.3), the effective degrees of
freedom follow the Welch-Satterthwaite formula (GUM G.4.1, eq. G.2b), and
the expanded uncertainty is U = k u_c with k the Student-t quantile for
nu_eff (GUM G.3.2; k = 1.96 for infinite degrees of freedom) unless a fixed
k is asked for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, cast

import numpy as np

from pipeline.maths.metrology.inputs import InputLike, InputSet
from pipeline.maths.metrology.intervals import CoverageInterval
from pipeline.maths.metrology.model import Model, evaluate_outputs

__all__ = ["K95", "BudgetLine", "LinearResult", "propagate_linear", "coverage_factor", "welch_satterthwaite"]

# Relative step of the central differences, in units of each input's u.
_STEP_IN_U = 1e-3
# Floor of that step relative to the estimate (not to 1: a lens coefficient of 1e-7 has a u of 1e-9): an input
# held nearly fixed (u = 1e-12 standing for "no uncertainty") would otherwise be stepped by a few ulps, and its
# sensitivity would be rounding noise that changes with the CPU's BLAS; every input with a meaningful u keeps
# its step of 1e-3 u.
_STEP_FLOOR = 1e-8


@dataclass(frozen=True)
class BudgetLine:
    """One input's line in an uncertainty budget.

    sensitivity : c_i = df/dx_i [output unit / input unit]
    contribution : u_i(y) = |c_i| u(x_i) [output unit]
    share : c_i^2 u(x_i)^2 / u_c^2, the input's fraction of the variance
    """

    label: str
    estimate: float
    u: float
    dof: float
    distribution: str
    sensitivity: float
    contribution: float
    share: float


@dataclass(frozen=True)
class LinearResult:
    """Result of the law of propagation of uncertainty for one output quantity.

    value : y = f(x) [output unit]
    u : combined standard uncertainty u_c(y) [output unit]
    dof : effective degrees of freedom nu_eff
    k : coverage factor; U = k u
    budget : one line per uncertain input
    correlation_share : share of u_c^2 from covariance terms (0 when
        the inputs are independent); budget shares plus this sum to 1
    sensitivity_method : "analytic" or "numeric (central differences)"
    """

    name: str
    value: float
    u: float
    dof: float
    k: float
    p: float
    budget: tuple[BudgetLine, ...]
    correlation_share: float
    sensitivity_method: str

    @property
    def U(self) -> float:
        """Expanded uncertainty U = k u [output unit]."""
        return self.k * self.u

    @property
    def interval(self) -> CoverageInterval:
        return CoverageInterval(self.value - self.U, self.value + self.U, self.p, "linear")

    def line(self, label: str) -> BudgetLine:
        for line in self.budget:
            if line.label == label:
                return line
        raise KeyError(label)


def welch_satterthwaite(contributions: np.ndarray, dofs: np.ndarray) -> float:
    """Effective degrees of freedom (GUM eq. G.2b).

    contributions : u_i(y) = |c_i| u(x_i) [output unit]
    dofs : nu_i of each input (inf for Type B)
    """
    contributions = np.asarray(contributions, dtype=float)
    dofs = np.asarray(dofs, dtype=float)
    u4 = float(np.sum(contributions**2)) ** 2
    finite = np.isfinite(dofs) & (contributions > 0)
    denom = float(np.sum(contributions[finite] ** 4 / dofs[finite]))
    return math.inf if denom == 0.0 else u4 / denom


def _source_terms(inputs: InputSet, c: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Welch-Satterthwaite's terms per independent source: u_s(y) = sqrt(c_s^T V_s c_s) and nu_s.

    GUM G.4.1 assumes independent inputs; a joint group's inputs share one
    estimate of their covariance with one nu, so the group's whole
    contribution is one term with that nu (Willink, Metrologia 44 (2007)
    340), and groups are independent of one another.
    """
    contributions, dofs = [], []
    for idx, nu in inputs.sources():
        cs = c[idx]
        contributions.append(math.sqrt(max(float(cs @ cov[np.ix_(idx, idx)] @ cs), 0.0)))
        dofs.append(nu)
    return np.array(contributions), np.array(dofs)


K95 = 1.959963984540054
"""k for a 95 % coverage of a normal distribution, ``coverage_factor(inf)``: the one place it is written."""


def coverage_factor(dof: float, p: float = 0.95) -> float:
    """k = t_{(1+p)/2, nu} (GUM G.3.2); 1.95996... for nu = inf and p = 0.95."""
    # scipy.special's quantiles are what scipy.stats.norm.ppf and t.ppf call (the same values), without the
    # 0.3-1.4 s scipy.stats costs to import
    from scipy import special

    if math.isinf(dof):
        return float(special.ndtri(0.5 * (1.0 + p)))
    return float(special.stdtrit(dof, 0.5 * (1.0 + p)))


def _step(x: float, u: float) -> float:
    """The central-difference step of an input with estimate x and standard uncertainty u (0: not stepped)."""
    return max(_STEP_IN_U * u, _STEP_FLOOR * abs(x)) if u > 0 else 0.0


def _numeric_jacobian(model: Model, inputs: InputSet, name: str) -> tuple[dict[str, float], dict[str, np.ndarray], bool]:
    """Values at the estimates and central-difference sensitivities, in one vectorised call."""
    members = inputs.members
    n = 1 + 2 * len(members)
    values: dict[str, np.ndarray | float] = {}
    for j, m in enumerate(members):
        column = np.full(n, m.x)
        h = _step(m.x, m.u)
        column[1 + 2 * j] += h
        column[2 + 2 * j] -= h
        values[m.label] = column
    values.update(inputs.constants)
    outputs, single = evaluate_outputs(model, values, n, name)
    y0 = {k: float(v[0]) for k, v in outputs.items()}
    jac: dict[str, np.ndarray] = {}
    for k, v in outputs.items():
        c = np.zeros(len(members))
        for j, m in enumerate(members):
            if m.u > 0:
                c[j] = (v[1 + 2 * j] - v[2 + 2 * j]) / (2.0 * _step(m.x, m.u))
        jac[k] = c
    return y0, jac, single


def propagate_linear(
    model: Model,
    inputs: InputLike,
    *,
    p: float = 0.95,
    k: float | None = None,
    sensitivities: Callable[..., Mapping[str, float] | Mapping[str, Mapping[str, float]]] | None = None,
    name: str = "y",
) -> LinearResult | dict[str, LinearResult]:
    """Propagate the input uncertainties through ``model`` by the GUM's first-order law.

    model : vectorised function of the input labels (see ``pipeline.maths.metrology.model``)
    inputs : the input quantities (InputSet or label -> Distribution / number)
    p : coverage probability of the expanded uncertainty
    k : fixed coverage factor (for example 2); None uses the Student-t
        quantile for the effective degrees of freedom
    sensitivities : optional analytic partial derivatives: a function of the
        input labels returning {label: c_i} (single output) or
        {output: {label: c_i}}; numeric central differences otherwise
    name : name of the output when ``model`` returns a single array

    Returns a LinearResult, or a dict of them when the model returns a mapping.
    """
    inputs = InputSet.of(inputs)
    members = inputs.members
    y0, jac, single = _numeric_jacobian(model, inputs, name)
    method = "numeric (central differences)"
    if sensitivities is not None:
        given = sensitivities(**inputs.estimates())
        # one output: {label: c_i}; several: {output: {label: c_i}}
        per_output = cast(Mapping[str, Mapping[str, float]], {name: given} if single else given)
        for out_name in jac:
            jac[out_name] = np.array([float(per_output[out_name].get(m.label, 0.0)) for m in members])
        method = "analytic"

    cov = inputs.covariance()
    u_in = np.array([m.u for m in members])
    results: dict[str, LinearResult] = {}
    for out_name, c in jac.items():
        variance = float(c @ cov @ c) if members else 0.0
        u_c = math.sqrt(max(variance, 0.0))
        contributions = np.abs(c) * u_in
        diag_var = float(np.sum(contributions**2))
        shares = contributions**2 / variance if variance > 0 else np.zeros_like(contributions)
        correlation_share = (variance - diag_var) / variance if variance > 0 else 0.0
        dof = welch_satterthwaite(*_source_terms(inputs, c, cov))
        k_used = coverage_factor(dof, p) if k is None else float(k)
        budget = tuple(
            BudgetLine(m.label, m.x, m.u, m.dof, m.describe, float(c[j]), float(contributions[j]), float(shares[j]))
            for j, m in enumerate(members)
        )
        results[out_name] = LinearResult(
            out_name, y0[out_name], u_c, dof, k_used, p, budget, correlation_share, method
        )
    return results[name] if single else results
