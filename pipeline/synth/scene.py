"""What a synthetic pipe contains: its profile, material, joints, water and defects.

Positions along the pipe are world Z [mm] (chainage x 1000); positions around
it are clock positions (12 = crown, 3 = right looking downstream). Every
defect carries the true dimensions the ground truth reports.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

import numpy as np

from pipeline.maths.profiles import SHAPES, clock_to_theta, profile_width
from pipeline.synth.texture import MATERIALS

__all__ = [
    "Pipe", "Crack", "Deformation", "DisplacedJoint", "JOINT_ENDS", "Deposit", "Connection", "Marker", "Scene", "Feature",
]


@dataclass(frozen=True)
class Pipe:
    """The pipe as built: shape, true internal height [mm], material, joint spacing [mm]."""

    shape: str
    height_mm: float
    material: str
    unit_length_mm: float
    joint_gap_mm: float | None = None   # None: the material's usual gap

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"shape must be one of {SHAPES}, got {self.shape!r}")
        if self.material not in MATERIALS:
            raise ValueError(f"material must be one of {sorted(MATERIALS)}, got {self.material!r}")
        if not 100.0 <= self.height_mm <= 2000.0:
            raise ValueError(f"height {self.height_mm} mm is outside 100-2000 mm")

    @property
    def width_mm(self) -> float:
        return profile_width(self.shape, self.height_mm)

    @property
    def gap_mm(self) -> float:
        return MATERIALS[self.material].joint_gap_mm if self.joint_gap_mm is None else self.joint_gap_mm


@dataclass(frozen=True)
class Crack:
    """A crack of true width [mm] on the wall.

    circumferential: around the pipe at z_mm, from clock_from to clock_to
    (clockwise); longitudinal: along the pipe at ``clock`` from z_mm over
    length_mm.
    """

    id: str
    orientation: str
    z_mm: float
    width_mm: float
    clock_from: float = 12.0
    clock_to: float = 12.0
    clock: float = 12.0
    length_mm: float = 0.0

    # A real crack wanders; these centre lines are what the renderer draws and
    # what the ground truth measures across.
    def centre_z(self, theta):
        """Circumferential crack: its centre line's Z [mm] at wall angle theta [rad]."""
        return self.z_mm + 12.0 * np.sin(3.0 * np.asarray(theta) + 0.7)

    def centre_u(self, z, r_eq: float):
        """Longitudinal crack: its centre line's arc position theta * r_eq [mm] at Z [mm]."""
        return clock_to_theta(self.clock) * r_eq + 10.0 * np.sin(np.asarray(z) / 90.0)


@dataclass(frozen=True)
class Deformation:
    """Vertical deformation (BAA A): the vertical dimension reduced by ``percent`` between z_from and z_to.

    The section becomes an ellipse whose invert stays in place; the change
    ramps in over ``ramp_mm`` at both ends. Circular pipes only.
    """

    id: str
    z_from_mm: float
    z_to_mm: float
    percent: float
    ramp_mm: float = 250.0


@dataclass(frozen=True)
class DisplacedJoint:
    """A joint (number k, at z = k * unit length) with a longitudinal gap and a radial step [mm].

    The pipe downstream of the joint is displaced by ``step_mm`` towards the
    clock position ``clock`` (6 = the next pipe sits lower).

    ``ends`` is how the two pipes meet (``JOINT_ENDS``):

    - "painted": the pipes meet at the joint's plane and the gap is a dark band painted across it, so where the far
      pipe stands into the flow its end face lies at the plane, inside the band (the generator's joint until
      2026-12-07's fourth session, every benchmark's and sample's so far);
    - "apart": the pipe ends stand the gap apart, as in a sewer: the near pipe ends gap / 2 before the plane, the
      far one begins gap / 2 beyond it, and where it stands into the flow its end face, lit head-on, shows just
      beyond the gap; where it stands out of the wall its end hides behind the near one's and the gap closes.
    """

    id: str
    joint: int
    gap_mm: float
    step_mm: float
    clock: float = 6.0
    ends: str = "painted"

    def __post_init__(self) -> None:
        if self.ends not in JOINT_ENDS:
            raise ValueError(f"displaced joint {self.id}: ends {self.ends!r} is not one of {', '.join(JOINT_ENDS)}")


JOINT_ENDS = ("painted", "apart")


@dataclass(frozen=True)
class Deposit:
    """Settled deposits (BBC) filling ``area_percent`` of the cross-section between z_from and z_to."""

    id: str
    z_from_mm: float
    z_to_mm: float
    area_percent: float


@dataclass(frozen=True)
class Connection:
    """A lateral connection of internal diameter [mm] at z_mm and a clock position.

    intrusion_mm > 0 makes it an intruding connection (BAG): the lateral's
    end stands inside the pipe by that length, measured from the wall.
    """

    id: str
    z_mm: float
    clock: float
    diameter_mm: float
    intrusion_mm: float = 0.0
    wall_mm: float = 12.0


@dataclass(frozen=True)
class Marker:
    """A small bright disc on the wall, a geometric target for tests."""

    z_mm: float
    clock: float
    radius_mm: float = 6.0


Feature = Union[Crack, Deformation, DisplacedJoint, Deposit, Connection, Marker]


@dataclass(frozen=True)
class Scene:
    """A pipe, its water level (BDD, % of the height) and its features."""

    pipe: Pipe
    water_percent: float = 0.0
    features: tuple[Feature, ...] = field(default_factory=tuple)

    def of_type(self, kind: type) -> list:
        return [f for f in self.features if isinstance(f, kind)]
