"""How the rendered video looks, apart from the scene's geometry: optics, response and the joints' look.

The detectors were developed on video of one look (``Appearance()``, the renderer's defaults). A contractor's
camera, or another generator, differs in all of it: the lens's blur, the response curve, the light's fall-off
towards the corners, how dark a joint's gap is and how bright the socket's end face. ``varied_appearance``
draws each of them from a range wider than any one camera's, so a benchmark can show what the image-alone
measurements do on video they were not tuned on (``benchmarks/automatic_joints.py --appearance varied``).
The sensor's noise stays the renderer's own argument (``Renderer(noise=...)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Appearance", "varied_appearance", "varied_look", "SENSOR_NOISE"]

SENSOR_NOISE = 2.0      # the renderer's sensor noise [grey levels of 255] unless said
DEFAULT_FACE_GAIN = 0.8  # the default look's socket face brightness factor (``Appearance.face_gain``)


@dataclass(frozen=True)
class Appearance:
    """The look of a rendered video (defaults: the look the detectors were developed on).

    blur_px : the optics' Gaussian blur, standard deviation [px];
    gamma : the display exponent after the logarithmic response [-] (brightness = tone ** gamma);
    tone_k : how strongly the logarithmic response compresses the bright near wall [-] (larger: the far pipe
        stays brighter against the near);
    vignette : share of the light lost in the image's corners [-] (with the square of the radius; before the
        logarithmic response, which compresses it);
    groove : share of the light a joint's gap swallows at its floor [-];
    face_gain : brightness of the socket's end face, lit head-on, against the grazing wall [-]; where a joint's
        pipe ends stand apart, the far end's face reflects ``face_albedo`` = face_gain / 0.8 times the wall's light by
        Lambert's law (1 in the default look: one material).
    """

    blur_px: float = 0.9
    gamma: float = 1 / 1.4
    tone_k: float = 20.0
    vignette: float = 0.0
    groove: float = 0.85
    face_gain: float = DEFAULT_FACE_GAIN

    @property
    def face_albedo(self) -> float:
        """The far pipe's end face's albedo over the wall's, where a joint's ends stand apart [-]: the face's
        brightness against the default look's, so that the varied look draws it 0.5-1.75 times one material's."""
        return self.face_gain / DEFAULT_FACE_GAIN

    def __post_init__(self) -> None:
        checks = {"blur_px": 0.3 <= self.blur_px <= 3.0, "gamma": 0.3 <= self.gamma <= 1.2,
                  "tone_k": 1.0 <= self.tone_k <= 200.0, "vignette": 0.0 <= self.vignette < 0.9,
                  "groove": 0.3 <= self.groove <= 1.0, "face_gain": 0.1 <= self.face_gain <= 2.0}
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"Appearance: {', '.join(f'{n}={getattr(self, n)!r}' for n in bad)} out of range")


def varied_appearance(rng: np.random.Generator) -> Appearance:
    """One look drawn at random, each part uniform over a range that holds the default and goes well beyond it:
    blur 0.5-1.8 px, display gamma 1/2.2-1/1.0, response strength 5-80, vignetting 0-40 %, a gap swallowing
    60-95 % of the light, the socket's face 0.4-1.4 times the default's brightness factor."""
    return Appearance(blur_px=float(rng.uniform(0.5, 1.8)), gamma=float(1.0 / rng.uniform(1.0, 2.2)),
                      tone_k=float(np.exp(rng.uniform(np.log(5.0), np.log(80.0)))),
                      vignette=float(rng.uniform(0.0, 0.4)), groove=float(rng.uniform(0.6, 0.95)),
                      face_gain=float(rng.uniform(0.4, 1.4)))


def varied_look(rng: np.random.Generator) -> tuple[float, Appearance]:
    """A sensor noise (0.5-5 grey levels of 255) and a look (``varied_appearance``) drawn together, in that order:
    what the benchmarks' ``--appearance varied`` renders each case with."""
    return float(rng.uniform(0.5, 5.0)), varied_appearance(rng)
