"""The validation set that does not share the estimator's models (issue 30): its camera, height and clicks are
drawn from what the delivery states, and differ from it by about the stated u."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.formats.certificate import load_certificate
from pipeline.synth.mismatch import click_noise, drawn_certificate, drawn_height

CERT = Path(__file__).resolve().parent.parent / "sample_videos" / "certificates" / "SYN-720x576.json"


def test_a_drawn_camera_differs_from_the_certificate_by_its_stated_u():
    cert = load_certificate(CERT).in_convention("opencv")
    rng = np.random.default_rng(4)
    draws = [drawn_certificate(cert, rng) for _ in range(300)]
    for name, p in cert.parameters.items():
        values = np.array([d.value(name) for d in draws])
        assert np.all(values != p.value)
        if p.u > 0:
            assert np.std(values) == pytest.approx(p.u, rel=0.15)
            assert abs(np.mean(values) - p.value) < 4 * p.u / np.sqrt(len(values))


def test_a_drawn_height_stays_within_the_tolerance_and_fills_it():
    rng = np.random.default_rng(1)
    h = np.array([drawn_height(400.0, 4.0, rng) for _ in range(2000)])
    assert h.min() >= 396.0 and h.max() <= 404.0
    assert np.std(h) == pytest.approx(4.0 / np.sqrt(3), rel=0.05)


def test_click_noise_has_the_declared_sd_but_heavier_tails_than_the_declared_normal():
    e = click_noise(0.7, (200_000, 2), np.random.default_rng(2))
    robust = 1.4826 * np.median(np.abs(e - np.median(e, axis=0)), axis=0)
    assert np.all(robust < 0.7)                       # the bulk is narrower than a normal of the same SD
    assert np.mean(np.abs(e) > 3 * 0.7) > 5 * 0.0027  # and the tails far heavier
