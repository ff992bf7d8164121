"""The look the generated benchmarks render with, chosen by ``--appearance`` (``pipeline.synth.appearance``)."""

from __future__ import annotations

import argparse

import numpy as np

from pipeline.synth.appearance import SENSOR_NOISE, Appearance, varied_look


def add_appearance_argument(ap: argparse.ArgumentParser) -> None:
    """``--appearance default|varied``: the look the cases are rendered with."""
    ap.add_argument("--appearance", choices=("default", "varied"), default="default",
                    help="the video's look: the one the detectors were developed on, or one drawn per case (blur, "
                         "response, vignetting, the joints' look, noise: pipeline.synth.appearance); the cases' "
                         "geometry is the same either way")


def look_of(appearance: str, rng: np.random.Generator) -> tuple[float, Appearance]:
    """The sensor noise [grey levels] and look of one case: drawn from ``rng`` (a stream of its own, so the
    geometry's draws stay those of the default run) for ``varied``, the default's for ``default``."""
    return varied_look(rng) if appearance == "varied" else (SENSOR_NOISE, Appearance())
