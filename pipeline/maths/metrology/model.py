"""Calling a vectorised measurement model.

A model is a plain function whose keyword arguments are the input labels and
which broadcasts like NumPy: called with arrays of trials it returns an array
of output trials. It returns either one array (a single output quantity) or a
mapping of output name -> array (several output quantities computed
together, for example X and Y of the collinearity equations). The same
function serves the linear method and the Monte Carlo method.
"""

from __future__ import annotations

from typing import Callable, Mapping, Union

import numpy as np

from pipeline.core.errors import ModelError

__all__ = ["Model", "evaluate_outputs"]

Model = Callable[..., Union[np.ndarray, float, Mapping[str, Union[np.ndarray, float]]]]


def evaluate_outputs(model: Model, values: Mapping[str, np.ndarray | float], n: int, name: str, *,
                     allow_nonfinite: bool = False) -> tuple[dict[str, np.ndarray], bool]:
    """Evaluate ``model(**values)``; return ({output name: array of shape (n,)}, single).

    ``single`` is True when the model returned one array rather than a mapping. A non-finite output raises
    ModelError unless ``allow_nonfinite`` (the caller then handles those trials).
    """
    with np.errstate(all="ignore"):
        out = model(**values)
    single = not isinstance(out, Mapping)
    raw = dict(out) if isinstance(out, Mapping) else {name: out}
    outputs: dict[str, np.ndarray] = {}
    for key, arr in raw.items():
        arr = np.broadcast_to(np.asarray(arr, dtype=float), (n,))
        if not allow_nonfinite and not np.all(np.isfinite(arr)):
            bad = int(np.count_nonzero(~np.isfinite(arr)))
            raise ModelError(
                f"model {getattr(model, '__name__', model)!r} returned {bad} non-finite value(s) "
                f"of output {key!r} out of {n}: some inputs fall outside the model's domain"
            )
        outputs[key] = arr
    return outputs, single
