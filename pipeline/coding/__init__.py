"""EN 13508-2 coding: the code table, the section header, the observation log and its marks, the package manifest."""

from .codes import CODES, Code, Quantification, code_spec, quantification
from .header import SectionHeader, header_from_dict, load_header
from .log import Mark, Observation, RowProblem, check_marks_in_frame, read_log, read_marks
from .package import PackageManifest, certificate_path, load_manifest

__all__ = ["CODES", "Code", "Quantification", "code_spec", "quantification", "SectionHeader", "header_from_dict",
           "load_header", "Mark", "Observation", "RowProblem", "check_marks_in_frame", "read_log", "read_marks",
           "PackageManifest", "certificate_path", "load_manifest"]
