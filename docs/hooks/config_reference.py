"""The Config reference page (``config.md``), generated from the settings' declarations.

Every key of a run's TOML config is declared once, as a field of the settings dataclasses in
``rangeproc/settings.py`` (``rangeproc.keys.key``: default, meaning, unit, allowed values or
bounds); ``rangeproc.config_reference.config_reference_markdown`` renders those declarations
into the page, so it lists exactly the keys the loader accepts.

As an MkDocs hook (``hooks: [docs/hooks/config_reference.py]`` in ``mkdocs.yml``) the page is
served as a generated file (:func:`on_files`): nothing is written into ``docs/``. As a script,
``python docs/hooks/config_reference.py --out FILE`` writes it for a look without MkDocs
(default: print it).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

#: The page's path under docs/.
URI = "config.md"


def _markdown() -> str:
    try:
        from rangeproc.config_reference import config_reference_markdown
    except ImportError:                    # run from a checkout without rangeproc installed
        sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
        from rangeproc.config_reference import config_reference_markdown
    return config_reference_markdown()


def on_files(files: Any, config: Any, **_: Any) -> Any:
    """MkDocs ``on_files``: add the generated config reference (replacing any file of the
    same path)."""
    from mkdocs.structure.files import File   # MkDocs >= 1.6 (the docs extra)
    old = files.get_file_from_path(URI)
    if old is not None:
        files.remove(old)
    files.append(File.generated(config, URI, content=_markdown()))
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, help="write the page to this file (default: print it)")
    a = ap.parse_args(argv)
    text = _markdown()
    if a.out:
        a.out.write_text(text, encoding="utf-8")
        print(f"wrote {a.out}")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
