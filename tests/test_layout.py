"""The house: rooms import only rooms below them (docs/layout.md), and every stage is a module
of rangeproc/stages/ named after it, in the order the run and its progress clock use."""
from __future__ import annotations

import ast
from pathlib import Path

import rangeproc.stages as stages

PACKAGE = Path(__file__).resolve().parents[1] / "rangeproc"

#: Layer of each room (top-level module or package of rangeproc): a room may import rooms of
#: its own or a lower layer only (docs/layout.md).
LAYERS = {
    0: {"__init__", "errors", "families", "keys", "settings", "results", "progress", "parallel",
        "quantiles", "run_warnings", "timescale", "kernel_cache", "summary_types",
        "summary_reference"},
    1: {"config_checks", "config", "io", "models", "frames"},
    2: {"config_reference", "editing"},
    3: {"estimation"},
    4: {"fusion"},
    5: {"tracking"},
    6: {"evaluate", "interchange", "report", "simulate"},
    7: {"stages", "planning"},
    8: {"pipeline"},
    9: {"campaign"},
    10: {"cli"},
}
LAYER = {room: layer for layer, rooms in LAYERS.items() for room in rooms}


def test_every_room_has_a_layer():
    rooms = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
             if (p.suffix == ".py" or (p.is_dir() and (p / "__init__.py").exists()))}
    assert rooms == set(LAYER), rooms ^ set(LAYER)


def test_no_room_imports_a_higher_one():
    upward = []
    for path in PACKAGE.rglob("*.py"):
        room = path.relative_to(PACKAGE).with_suffix("").parts[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("rangeproc."):
                target = node.module.split(".")[1]
                if LAYER[target] > LAYER[room]:
                    upward.append(f"{path.relative_to(PACKAGE)} imports {node.module}")
    assert not upward, upward


def test_the_stages_are_modules_in_order():
    assert stages.STAGES == ("read", "screen", "assemble", "associate", "fuse", "products",
                             "write", "report")
    for name in stages.STAGES:
        assert (PACKAGE / "stages" / f"{name}.py").is_file(), name
    pipeline = (PACKAGE / "pipeline.py").read_text()
    positions = [pipeline.index(f'clock.stage("{name}"') for name in stages.STAGES]
    assert positions == sorted(positions)
