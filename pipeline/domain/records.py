"""The typed records that cross floors: what was delivered, as every format's reader returns it.

A reader of any format (``pipeline.formats``) returns a ``SectionHeader`` and
``Observation`` records, each carrying the ``RowProblem`` of its row; marks
come as ``Mark`` records. The measurement, the verdicts and the store take
these, never a format's own rows. The records of what pipegauge makes of them
(an inspection, a measured quantity, its verdicts) are in ``pipeline.domain.results``.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import asdict, dataclass, field

from pipeline.domain.codes import CODES, Quantification

__all__ = ["RowProblem", "Observation", "Mark", "SectionHeader", "DISTANCE_SLACK_M"]

DISTANCE_SLACK_M = 0.05      # a distance may pass the section length by the counter's rounding [m]


@dataclass(frozen=True)
class RowProblem:
    """Why one row of a delivered file cannot be used as it is."""

    file: str
    where: str        # "row 3" (the log's row number as delivered) or "line 5" (a line of marks.csv)
    field: str
    message: str
    # the (row, quantity) of the log a refused mark leaves unmeasured, when it names one (marks.csv)
    quantity: tuple[int, str] | None = None

    def __str__(self) -> str:
        return f"{self.file} {self.where}, field {self.field!r}: {self.message}"


@dataclass
class Observation:
    """One record of the log, parsed; ``fields`` keeps the text as delivered."""

    row: int
    distance_m: float
    code: str
    char1: str
    char2: str
    q1: float | None
    q1_unit: str
    q2: float | None
    q2_unit: str
    clock_from: int | None
    clock_to: int | None
    at_joint: bool
    continuous: str
    video_time_s: float | None
    photo: str
    remark: str
    fields: dict[str, str]
    problems: list[RowProblem] = field(default_factory=list)
    ref: str = ""         # the delivered record's own id when its format has one (a VSA-KEK Kanalschaden TID)
    grade: str = ""       # the contractor's condition grade when delivered (VSA-KEK Einzelschadenklasse)

    def quantification(self, which: str) -> Quantification | None:
        spec = CODES.get(self.code)
        return spec.quantification(which, self.char1) if spec else None


@dataclass(frozen=True)
class Mark:
    """The two points marked for one quantity, in the video frame as recorded (distorted) [px]."""

    row: int
    quantity: str
    frame: int
    a: tuple[float, float]
    b: tuple[float, float]
    u_px: float          # standard uncertainty of each coordinate [px]
    lines: tuple[int, int]


@dataclass(frozen=True)
class SectionHeader:
    """A pipe section as the contractor's header describes it (lengths in mm, chainage in m)."""

    section_id: str               # AAA
    start_node: str               # AAD
    finish_node: str              # AAF
    direction: str                # AAK: downstream | upstream
    shape: str                    # ACA: circular | egg
    height_mm: float              # ACB: nominal internal height H [mm]
    width_mm: float               # ACC [mm]
    height_tolerance_mm: float    # half-width of the tolerance of H [mm], rectangular
    material: str                 # ACD
    pipe_unit_length_m: float     # ACG [m]
    section_length_m: float       # [m]
    inspection_date: dt.date      # ABF
    contractor: str = ""
    site: str = ""                # AAB
    longitudinal_reference: str = "start node wall"   # ABC

    def as_record(self) -> dict:
        record = asdict(self)
        record["inspection_date"] = self.inspection_date.isoformat()
        return record


