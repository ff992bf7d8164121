"""Labelled input quantities of a measurement model.

An :class:`InputSet` maps each input's label to what is known of it: a
:class:`~pipeline.maths.metrology.distributions.Distribution`, a member of a
:class:`~pipeline.maths.metrology.distributions.JointNormal` group, or a plain number
(a constant, known exactly). Labels are the model function's keyword
arguments, so an uncertainty budget falls out of the calculation with the
names the model uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping, Union

import numpy as np

from pipeline.maths.metrology.distributions import Distribution, JointNormal

__all__ = ["InputSet", "InputLike"]

InputLike = Union["InputSet", Mapping[str, Union[Distribution, float, int]]]


@dataclass(frozen=True)
class _Member:
    """One uncertain input: where its estimate, u and draws come from."""

    label: str
    x: float
    u: float
    dof: float
    kind: str
    describe: str


class InputSet:
    """The input quantities X_1..X_N of a model, with their labels.

    independent : label -> Distribution (independent of every other input) or
        a number (a constant, u = 0)
    joint : groups of jointly normal inputs with a covariance matrix
    """

    def __init__(
        self,
        independent: Mapping[str, Distribution | float | int] | None = None,
        joint: Iterable[JointNormal] = (),
    ) -> None:
        independent = dict(independent or {})
        self._constants: dict[str, float] = {}
        self._independent: dict[str, Distribution] = {}
        for label, item in independent.items():
            if isinstance(item, Distribution):
                self._independent[label] = item
            elif isinstance(item, (int, float, np.floating, np.integer)) and not isinstance(item, bool):
                if not math.isfinite(float(item)):
                    raise ValueError(f"input {label!r}: constant must be finite, got {item!r}")
                self._constants[label] = float(item)
            else:
                raise TypeError(
                    f"input {label!r}: expected a Distribution or a number, got {type(item).__name__}"
                )
        self._joint: tuple[JointNormal, ...] = tuple(joint)
        seen = set(independent)
        for group in self._joint:
            clash = seen.intersection(group.labels)
            if clash:
                raise ValueError(f"input labels given twice: {sorted(clash)}")
            seen.update(group.labels)

        members: list[_Member] = []
        for label, dist in self._independent.items():
            members.append(_Member(label, float(dist.x), float(dist.u), float(dist.dof), dist.kind, dist.describe()))
        for group in self._joint:
            for i, label in enumerate(group.labels):
                x, u = float(group.x[i]), float(np.sqrt(group.cov[i, i]))
                members.append(_Member(label, x, u, group.dof, group.kind, f"{group.kind}(x={x:.6g}, u={u:.3g})"))
        self._members = tuple(members)
        self._index = {m.label: i for i, m in enumerate(members)}

    @classmethod
    def of(cls, inputs: InputLike) -> "InputSet":
        """An InputSet from an InputSet or a plain mapping of label -> distribution."""
        return inputs if isinstance(inputs, InputSet) else cls(inputs)

    def extended(self, more: Mapping[str, Distribution | float | int]) -> "InputSet":
        """A new InputSet with further independent inputs or constants added."""
        return InputSet({**self._independent, **self._constants, **more}, joint=self._joint)

    # -- what the linear method needs --------------------------------------
    @property
    def labels(self) -> tuple[str, ...]:
        """Labels of the uncertain inputs, in budget order."""
        return tuple(m.label for m in self._members)

    @property
    def members(self) -> tuple[_Member, ...]:
        return self._members

    @property
    def constants(self) -> dict[str, float]:
        return dict(self._constants)

    def estimates(self) -> dict[str, float]:
        """Label -> estimate, constants included."""
        values = {m.label: m.x for m in self._members}
        values.update(self._constants)
        return values

    def sources(self) -> list[tuple[list[int], float]]:
        """The independent sources of uncertainty: (indices into ``labels``, degrees of freedom), one per
        independent input and one per joint group (its inputs share one estimate of their covariance)."""
        out: list[tuple[list[int], float]] = [([self._index[label]], float(dist.dof))
                                              for label, dist in self._independent.items()]
        out += [([self._index[label] for label in group.labels], float(group.dof)) for group in self._joint]
        return out

    def covariance(self) -> np.ndarray:
        """Covariance matrix of the uncertain inputs, in the order of ``labels``."""
        n = len(self._members)
        cov = np.zeros((n, n))
        for m in self._members:
            i = self._index[m.label]
            cov[i, i] = m.u**2
        for group in self._joint:
            idx = [self._index[label] for label in group.labels]
            cov[np.ix_(idx, idx)] = group.cov
        return cov

    @property
    def correlated(self) -> bool:
        """True when some inputs share a non-zero covariance."""
        cov = self.covariance()
        return bool(np.any(cov - np.diag(np.diag(cov))))

    # -- what the Monte Carlo method needs ---------------------------------
    def sample(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray | float]:
        """``n`` joint draws of every input, label -> array of shape (n,).

        Constants are passed through as floats, so models must broadcast.
        The order of draws is fixed (independent inputs in insertion order,
        then joint groups), which makes a run reproducible from its seed.
        """
        draws: dict[str, np.ndarray | float] = {}
        for label, dist in self._independent.items():
            draws[label] = dist.sample(rng, n)
        for group in self._joint:
            block = group.sample(rng, n)
            for i, label in enumerate(group.labels):
                draws[label] = block[:, i]
        draws.update(self._constants)
        return draws
