"""The house (docs/architecture.md): the floors are the folders of pipeline/, every import points down, and each
file format's name is written once.

The checks are functions of a source tree, so that each is also shown to fail: on a copy of pipeline/ with a
wrong-way import planted, and with a second definition of a format's name planted.
"""

from __future__ import annotations

import ast
import importlib
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PIPELINE = ROOT / "pipeline"

# The floors, bottom up: a module may import its own floor folder and the floors below, never a floor folder of
# the same number (sideways) or above. pipeline/__init__.py (the version) is the ground under all of them.
FLOORS = {
    "core": 0,          # errors, limits, atomic writes, text and number helpers
    "maths": 1,         # the GUM engine, cross-section profiles
    "domain": 2,        # the EN 13508-2 code table, the typed records
    "camera": 3,        # certificate object, distortion, pose, the measurement models
    "vision": 4,        # the contour in images, the video, its overlay and track
    "measurement": 5,   # quantities with U95 and their budgets
    "judgement": 6,     # the log check, the surveyed length, condition grades
    "formats": 7,       # every file format, read and written
    "store": 7,         # the Parquet dataset: records to rows and back
    "reports": 8,       # PDF reports
    "app": 9,           # the conductor, the inbox, the verbs' procedures (calibration, the paper, exports)
    "synth": 10,        # the synthetic generator: a consumer, like a test
}
NOT_CODE = {"data", "__pycache__"}


def _module(path: Path, root: Path) -> str:
    return ".".join(path.relative_to(root).with_suffix("").parts)


def _floor(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in FLOORS else None     # None: pipeline itself (`__version__`)


def imports(path: Path, root: Path) -> list[tuple[str, int]]:
    """(imported pipeline module, line) of every import in a file, relative imports resolved."""
    module = _module(path, root)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    package = package.removesuffix(".__init__")
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out += [(target, node.lineno)] if target.startswith("pipeline") else []
        elif isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.startswith("pipeline")]
    return out


def climbing_imports(root: Path) -> list[str]:
    """Every import in ``root/pipeline`` that goes to a floor above its own, or sideways to another folder."""
    found = []
    for path in sorted((root / "pipeline").rglob("*.py")):
        mine = _floor(_module(path, root))
        for target, line in imports(path, root):
            other = _floor(target)
            if mine is None or other is None or other == mine:
                continue
            if FLOORS[other] >= FLOORS[mine]:
                found.append(f"{path.relative_to(root)}:{line} ({mine}, floor {FLOORS[mine]}) imports {target} "
                             f"({other}, floor {FLOORS[other]})")
    return found


def format_names() -> dict[str, str]:
    """Each registered file format's name -> the module that defines it (``pipeline.formats.FILE_FORMATS``)."""
    from pipeline.formats import FILE_FORMATS

    names = {}
    for module in FILE_FORMATS.values():
        mod = importlib.import_module(module)
        if isinstance(getattr(mod, "FORMAT_NAME", None), str):
            names[mod.FORMAT_NAME] = module
        for model, _date in getattr(mod, "MODELS", {}).values():     # an INTERLIS format: its models' names
            names[model] = module
    return names


DEFINING = ("FORMAT_NAME", "MODELS")       # the attributes a format's module defines its names in


def _assigns(tree: ast.Module, attributes: tuple[str, ...]) -> bool:
    """Whether a module assigns one of ``attributes`` at its top level."""
    targets = [t for n in tree.body if isinstance(n, (ast.Assign, ast.AnnAssign))
               for t in (n.targets if isinstance(n, ast.Assign) else [n.target])]
    return any(isinstance(t, ast.Name) and t.id in attributes for t in targets)


def format_name_definitions(root: Path, names: dict[str, str]) -> list[str]:
    """Every string literal equal to a format's name outside the module that defines it, in pipeline/ and flows/.

    A format registered as a package (pipeline/formats/vsa_kek/) defines its names in the one module of the
    package that assigns FORMAT_NAME or MODELS; its other modules import them like everyone else.
    """
    found = []
    for folder in ("pipeline", "flows"):
        for path in sorted((root / folder).rglob("*.py")):
            module = _module(path, root).removesuffix(".__init__")
            tree = ast.parse(path.read_text(encoding="utf-8"))
            defines = _assigns(tree, DEFINING)
            own = {owner for owner in names.values()
                   if module == owner or (module.startswith(owner + ".") and defines)}
            for node in ast.walk(tree):
                if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names \
                        and names[node.value] not in own:
                    found.append(f"{path.relative_to(root)}:{node.lineno} writes {node.value!r}, "
                                 f"defined in {names[node.value]}")
    return found


def _copy(tmp_path: Path) -> Path:
    shutil.copytree(PIPELINE, tmp_path / "pipeline", ignore=shutil.ignore_patterns("__pycache__", "data"))
    shutil.copytree(ROOT / "flows", tmp_path / "flows", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def test_the_floors_are_the_folders_of_pipeline():
    rooms = {p.name for p in PIPELINE.iterdir() if p.name not in NOT_CODE and p.name != "__init__.py"}
    assert rooms == set(FLOORS), f"a floor for each folder, a folder for each floor: {sorted(rooms ^ set(FLOORS))}"
    assert all((PIPELINE / r / "__init__.py").is_file() for r in FLOORS)


def test_no_module_imports_upward_or_sideways():
    found = climbing_imports(ROOT)
    assert not found, "imports that climb:\n" + "\n".join(found)


def test_a_planted_wrong_way_import_is_caught(tmp_path):
    root = _copy(tmp_path)
    (root / "pipeline" / "maths" / "planted.py").write_text("from pipeline.app import measure_package\n")
    (root / "pipeline" / "store" / "planted.py").write_text("from ..formats.header import load_header\n")
    found = climbing_imports(root)
    assert len(found) == 2
    assert "pipeline/maths/planted.py:1 (maths, floor 1) imports pipeline.app" in found[0]
    assert "pipeline/store/planted.py:1 (store, floor 7) imports pipeline.formats.header" in found[1]


def test_every_format_name_is_written_once():
    names = format_names()
    assert {"pipegauge-inspection-package", "pipegauge-section-header", "pipegauge-calibration-certificate",
            "VSA_KEK_2019_LV95"} <= set(names)
    found = format_name_definitions(ROOT, names)
    assert not found, "format names written outside their format's module:\n" + "\n".join(found)


def test_a_planted_second_definition_of_a_format_name_is_caught(tmp_path):
    root = _copy(tmp_path)
    report = root / "pipeline" / "reports" / "planted.py"
    report.write_text('HEADER = {"format": "pipegauge-section-header", "format_version": 1}\n')
    (root / "flows" / "planted.py").write_text('MODEL = "VSA_KEK_2019_LV95"\n')
    # inside the format's own package, but not in the module that defines the names
    (root / "pipeline" / "formats" / "vsa_kek" / "planted.py").write_text('MODEL = "VSA_KEK_2020_1_LV95"\n')
    found = format_name_definitions(root, format_names())
    assert found == ["pipeline/formats/vsa_kek/planted.py:1 writes 'VSA_KEK_2020_1_LV95', defined in pipeline.formats.vsa_kek",
                     "pipeline/reports/planted.py:1 writes 'pipegauge-section-header', defined in pipeline.formats.header",
                     "flows/planted.py:1 writes 'VSA_KEK_2019_LV95', defined in pipeline.formats.vsa_kek"]


def test_no_production_module_imports_the_generator():
    users = [f"{p.relative_to(ROOT)}:{line}" for p in PIPELINE.rglob("*.py") if "synth" not in p.relative_to(PIPELINE).parts
             for target, line in imports(p, ROOT) if target.startswith("pipeline.synth")]
    flows = [f"{p.relative_to(ROOT)}:{line}" for p in (ROOT / "flows").glob("*.py") for target, line in imports(p, ROOT)
             if target.startswith("pipeline.synth") and p.name != "cli.py"]
    assert not users and not flows, users + flows


def test_the_coverage_factor_is_not_written_as_a_literal():
    """k for 95 % comes from pipeline.maths.metrology (coverage_factor, K95), never a 1.96 typed again."""
    found = [f"{p.relative_to(ROOT)}:{node.lineno}" for p in PIPELINE.rglob("*.py")
             if p.relative_to(PIPELINE).parts[:2] != ("maths", "metrology")
             for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
             if isinstance(node, ast.Constant) and node.value == 1.96]
    assert not found, found


def _loaded_after(statement: str) -> set[str]:
    code = f"import sys; {statement}; print('\\n'.join(sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(out.split())


@pytest.mark.slow
def test_the_library_never_loads_prefect_and_the_models_load_no_video_stack():
    everything = _loaded_after("import pipeline, pipeline.app, pipeline.store, pipeline.reports, "
                               "pipeline.formats, pipeline.measurement, pipeline.vision.video, pipeline.vision.contour")
    assert "prefect" not in everything
    models = _loaded_after("import pipeline.measurement, pipeline.camera, pipeline.maths.metrology")
    assert not {m for m in models if m.startswith(("pipeline.vision.video", "pipeline.reports", "pipeline.synth",
                                                   "rapidocr", "reportlab", "onnxruntime"))}
    # scipy.stats costs a second at every start-up for two quantiles that scipy.special gives
    assert not {m for m in everything | models if m.startswith("scipy.stats")}
