"""Probability distributions assigned to input quantities (JCGM 101 clause 6).

Each distribution knows its estimate (expectation), its standard uncertainty,
its degrees of freedom for the linear method, and how to draw trials for the
Monte Carlo method. Draws are vectorised: ``sample(rng, n)`` returns ``n``
values at once.

Domain: every location is a finite real; every width or standard uncertainty
is finite and >= 0 (0 means the quantity is known exactly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

__all__ = [
    "Distribution",
    "Normal",
    "Rectangular",
    "Triangular",
    "StudentT",
    "Arcsine",
    "JointNormal",
]


def _require_finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


def _require_width(name: str, value: float) -> float:
    value = _require_finite(name, value)
    if value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


class Distribution:
    """Base class: a univariate distribution for one input quantity.

    Subclasses define ``x`` (estimate), ``u`` (standard uncertainty), ``dof``
    (degrees of freedom, ``inf`` for a Type B evaluation) and ``sample``.
    """

    x: float
    u: float
    dof: float = math.inf
    kind: str = "distribution"

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def describe(self) -> str:
        """Short text for an uncertainty budget, e.g. ``N(1000, 1)``."""
        return f"{self.kind}(x={self.x:.6g}, u={self.u:.3g})"


@dataclass(frozen=True)
class Normal(Distribution):
    """Gaussian N(x, u^2) (JCGM 101 6.4.7).

    x : estimate [unit of the quantity]
    u : standard uncertainty [same unit], >= 0
    dof : degrees of freedom for Welch-Satterthwaite (inf for Type B)
    """

    x: float
    u: float
    dof: float = math.inf
    kind: str = field(default="normal", init=False)

    def __post_init__(self) -> None:
        _require_finite("x", self.x)
        _require_width("u", self.u)
        if not self.dof > 0:
            raise ValueError(f"dof must be > 0, got {self.dof!r}")

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.x + self.u * rng.standard_normal(n)


@dataclass(frozen=True)
class Rectangular(Distribution):
    """Rectangular (uniform) on [x - a, x + a] (JCGM 101 6.4.2); u = a / sqrt(3).

    x : centre [unit]
    a : half-width [same unit], >= 0
    """

    x: float
    a: float
    kind: str = field(default="rectangular", init=False)

    def __post_init__(self) -> None:
        _require_finite("x", self.x)
        _require_width("a", self.a)

    @classmethod
    def from_u(cls, x: float, u: float) -> "Rectangular":
        """The rectangular distribution with standard uncertainty ``u``."""
        return cls(x, math.sqrt(3.0) * _require_width("u", u))

    @property
    def u(self) -> float:  # type: ignore[override]
        return self.a / math.sqrt(3.0)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.x + self.a * (2.0 * rng.random(n) - 1.0)


@dataclass(frozen=True)
class Triangular(Distribution):
    """Symmetric triangular on [x - a, x + a] (JCGM 101 6.4.5); u = a / sqrt(6).

    x : mode and centre [unit]
    a : half-width [same unit], >= 0
    """

    x: float
    a: float
    kind: str = field(default="triangular", init=False)

    def __post_init__(self) -> None:
        _require_finite("x", self.x)
        _require_width("a", self.a)

    @property
    def u(self) -> float:  # type: ignore[override]
        return self.a / math.sqrt(6.0)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        # Sum of two independent U(-a/2, a/2) is triangular on [-a, a].
        r = rng.random((2, n))
        return self.x + self.a * (r[0] + r[1] - 1.0)


@dataclass(frozen=True)
class StudentT(Distribution):
    """Scaled and shifted t distribution t_nu(x, s^2) (JCGM 101 6.4.9).

    This is what a Type A evaluation from ``n`` indications gives: ``x`` the
    mean, ``s`` the standard deviation of the mean (``s_sample / sqrt(n)``),
    ``dof = n - 1``.

    For the linear method (JCGM 100 G.6) the standard uncertainty is ``s`` with
    ``dof`` degrees of freedom; the Monte Carlo draws follow the t distribution
    itself, whose standard deviation is ``s * sqrt(dof / (dof - 2))`` for
    ``dof > 2``.

    x : location [unit]
    s : scale [same unit], >= 0
    dof : degrees of freedom, > 0
    """

    x: float
    s: float
    dof: float
    kind: str = field(default="student-t", init=False)

    def __post_init__(self) -> None:
        _require_finite("x", self.x)
        _require_width("s", self.s)
        if not (self.dof > 0 and math.isfinite(self.dof)):
            raise ValueError(f"dof must be finite and > 0, got {self.dof!r}")

    @property
    def u(self) -> float:  # type: ignore[override]
        return self.s

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.x + self.s * rng.standard_t(self.dof, n)


@dataclass(frozen=True)
class Arcsine(Distribution):
    """Arcsine (U-shaped) on [x - a, x + a] (JCGM 101 6.4.6); u = a / sqrt(2).

    Typical of a sinusoidally varying quantity (a temperature cycling, a
    vibrating mount).

    x : centre [unit]
    a : half-width [same unit], >= 0
    """

    x: float
    a: float
    kind: str = field(default="arcsine", init=False)

    def __post_init__(self) -> None:
        _require_finite("x", self.x)
        _require_width("a", self.a)

    @property
    def u(self) -> float:  # type: ignore[override]
        return self.a / math.sqrt(2.0)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.x + self.a * np.sin(2.0 * math.pi * rng.random(n))


@dataclass(frozen=True)
class JointNormal:
    """Jointly normal input quantities with a covariance matrix (JCGM 101 6.4.8), or, with finite ``dof``, jointly
    t-distributed (the multivariate t of a covariance estimated from data, JCGM 102 5.3.3; the univariate case
    is JCGM 101 6.4.9).

    labels : names of the quantities, in the order of ``x`` and ``cov``
    x : estimates [units of each quantity]
    cov : covariance matrix [products of the units], symmetric positive
        semi-definite; with finite ``dof`` the scale matrix of the t: the
        covariance the linear method uses, with ``dof`` degrees of freedom
        (its Monte Carlo draws have covariance dof / (dof - 2) cov, as a
        ``StudentT`` has)
    dof : degrees of freedom of ``cov`` (inf: known, a normal)
    """

    labels: tuple[str, ...]
    x: np.ndarray
    cov: np.ndarray
    kind: str = field(default="normal (joint)", init=False)
    dof: float = math.inf
    _factor: np.ndarray = field(init=False, repr=False, compare=False)

    def __init__(self, labels: Sequence[str], x: Sequence[float] | np.ndarray, cov: Sequence[Sequence[float]] | np.ndarray,
                 dof: float = math.inf):
        labels = tuple(labels)
        x_arr = np.asarray(x, dtype=float)
        cov_arr = np.asarray(cov, dtype=float)
        n = len(labels)
        if len(set(labels)) != n:
            raise ValueError(f"JointNormal labels must be distinct: {labels}")
        if x_arr.shape != (n,) or cov_arr.shape != (n, n):
            raise ValueError(
                f"JointNormal needs {n} estimates and a {n}x{n} covariance, "
                f"got shapes {x_arr.shape} and {cov_arr.shape}"
            )
        if not (np.all(np.isfinite(x_arr)) and np.all(np.isfinite(cov_arr))):
            raise ValueError("JointNormal estimates and covariance must be finite")
        if not float(dof) > 0:
            raise ValueError(f"JointNormal dof must be > 0, got {dof!r}")
        if not np.allclose(cov_arr, cov_arr.T, rtol=1e-10, atol=0.0):
            raise ValueError("JointNormal covariance must be symmetric")
        eigval, eigvec = np.linalg.eigh(cov_arr)
        scale = max(float(np.max(np.abs(eigval))), np.finfo(float).tiny)
        if np.min(eigval) < -1e-10 * scale:
            raise ValueError("JointNormal covariance must be positive semi-definite")
        # An eigen-factor works for singular (fully correlated) covariances too,
        # where a Cholesky factor does not exist.
        factor = eigvec * np.sqrt(np.clip(eigval, 0.0, None))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "x", x_arr)
        object.__setattr__(self, "cov", cov_arr)
        object.__setattr__(self, "kind", "normal (joint)" if math.isinf(dof) else f"t (joint, nu={float(dof):.3g})")
        object.__setattr__(self, "dof", float(dof))
        object.__setattr__(self, "_factor", factor)

    @property
    def u(self) -> np.ndarray:
        """Standard uncertainties, the square roots of the diagonal."""
        return np.sqrt(np.diag(self.cov))

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draws of shape (n, len(labels)): normal, or multivariate t (a normal draw divided by one
        sqrt(chi^2_nu / nu) per trial, shared by the group's quantities) for finite ``dof``."""
        z = rng.standard_normal((n, len(self.labels)))
        if math.isfinite(self.dof):
            z = z / np.sqrt(rng.chisquare(self.dof, n) / self.dof)[:, None]
        return self.x + z @ self._factor.T
