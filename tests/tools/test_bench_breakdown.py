"""The bench's fuse-stage breakdown (``bench/breakdown.py``) times functions where the fusion
calls them; a function that moves leaves its time in "other" (12.5 of 13.3 fuse seconds
before these tests), so every wrapped name must be there."""
from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))          # bench/ is scripts, not a package
import breakdown  # noqa: E402


def test_every_part_is_called_from_where_it_is_wrapped() -> None:
    """Each (module, name) is an attribute of its module and its module's own code uses it (a
    call, or a ``partial`` of it): an import left behind after the call moved would pass the
    first check alone."""
    for (module, name), label in breakdown.FUSE_PARTS.items():
        mod = importlib.import_module(module)
        assert callable(getattr(mod, name, None)), (module, name, label)
        tree = ast.parse(Path(mod.__file__).read_text())
        used = [n for n in ast.walk(tree)
                if isinstance(n, ast.Name) and n.id == name and isinstance(n.ctx, ast.Load)]
        assert used, (module, name, label)


def test_remainder_is_the_stage_less_its_top_level_parts() -> None:
    """"other" (``remainders``): the stage's seconds less its parts', nested parts (a label
    that starts with spaces) counted in their parent only; stages without parts have none."""
    records = [{"label": "read", "seconds": 1.0, "calls": 1},
               {"label": "fuse", "seconds": 10.0, "calls": 1},
               {"label": "fuse: process noise search", "seconds": 3.0, "calls": 2},
               {"label": "fuse:   forward filters (q candidates)", "seconds": 5.0, "calls": 16},
               {"label": "fuse: filter + smoother pass", "seconds": 4.0, "calls": 3},
               {"label": "fuse:   forward filter", "seconds": 3.0, "calls": 3}]
    assert breakdown.remainders(records) == {"fuse": 3.0}


def test_wrapped_parts_record_their_calls(monkeypatch) -> None:
    """A wrapped part counts its calls and seconds under the stage open when it is called,
    and returns what the function returns."""
    from rangeproc.fusion import centralised

    where = breakdown.Breakdown()
    monkeypatch.setattr(breakdown, "FUSE_PARTS",
                        {("rangeproc.fusion.centralised", "output_grid"): "grid"})
    monkeypatch.setattr(centralised, "output_grid", centralised.output_grid)   # undone after
    where.wrap_fuse_parts()
    where.start("fuse", 1)
    grid = centralised.output_grid(0.0, 1.0, 10.0)
    where.finish("fuse", 0.0)
    rec = {r["label"]: r for r in where.records()}
    assert len(grid) == 11 and rec["fuse: grid"]["calls"] == 1
    assert rec["fuse"]["seconds"] >= rec["fuse: grid"]["seconds"] >= 0.0
