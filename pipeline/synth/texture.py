"""Procedural wall textures for the pipe materials.

A texture is an albedo map indexed [z, u]: z along the pipe and u along the
wall's circumference, both in texels of ``TEXEL_MM`` mm, periodic in both
directions. Colours are BGR (OpenCV order), in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["TEXEL_MM", "Material", "MATERIALS", "wall_texture"]

TEXEL_MM = 2.0


@dataclass(frozen=True)
class Material:
    """Look of a pipe material: BGR tint, mean albedo, and texture amplitudes."""

    name: str
    label: str                 # as written on an on-screen display, e.g. "Concrete"
    tint_bgr: tuple[float, float, float]
    albedo: float
    grain: float               # fine noise amplitude
    stains: float              # low-frequency blotches amplitude
    speckle: float             # aggregate speckles amplitude (concrete)
    joint_gap_mm: float        # ordinary joint gap


MATERIALS = {
    "concrete": Material("concrete", "Concrete", (0.60, 0.66, 0.72), 0.42, 0.10, 0.60, 0.25, 8.0),
    "vitrified clay": Material("vitrified clay", "Vitrified Clay", (0.30, 0.50, 0.85), 0.50, 0.06, 0.70, 0.0, 6.0),
    "plastic": Material("plastic", "PVC", (0.40, 0.60, 0.85), 0.65, 0.02, 0.15, 0.0, 4.0),
}


def _periodic_noise(rng: np.random.Generator, shape: tuple[int, int], cells: tuple[int, int]) -> np.ndarray:
    """Smooth periodic noise in [-1, 1] of ``shape`` with about ``cells`` features per period."""
    small = rng.standard_normal((cells[0], cells[1])).astype(np.float32)
    tiled = np.tile(small, (3, 3))
    big = cv2.resize(tiled, (shape[1] * 3, shape[0] * 3), interpolation=cv2.INTER_CUBIC)
    out = big[shape[0]:2 * shape[0], shape[1]:2 * shape[1]]
    return out / (np.abs(out).max() + 1e-6)


def wall_texture(material: Material, circumference_mm: float, period_mm: float, rng: np.random.Generator) -> np.ndarray:
    """Albedo map (nz, nu) float32 for a wall of the given circumference, periodic over ``period_mm`` along z."""
    nu = max(64, int(round(circumference_mm / TEXEL_MM)))
    nz = max(64, int(round(period_mm / TEXEL_MM)))
    tex = np.full((nz, nu), material.albedo, dtype=np.float32)
    tex += material.stains * material.albedo * _periodic_noise(rng, (nz, nu), (max(2, nz // 60), max(2, nu // 60)))
    tex += 0.5 * material.stains * material.albedo * _periodic_noise(rng, (nz, nu), (max(2, nz // 15), max(2, nu // 15)))
    tex += material.grain * material.albedo * rng.standard_normal((nz, nu)).astype(np.float32)
    if material.speckle:
        spots = rng.random((nz, nu)) < 0.03
        tex[spots] += material.speckle * material.albedo * rng.choice([-1.0, 1.0], size=int(spots.sum()))
    # Soften texel edges: hard per-texel steps cost video bitrate and look synthetic.
    padded = np.pad(tex, 4, mode="wrap")
    tex = cv2.GaussianBlur(padded, (0, 0), 1.0)[4:-4, 4:-4]
    return np.clip(tex, 0.02, 1.0).astype(np.float32)
