"""The tables of ``summary.json`` on the Outputs page, generated from the declaration.

Every section of ``summary.json`` is declared once, as a ``TypedDict`` of
``rangeproc/summary_types.py`` whose keys carry what they hold;
``rangeproc.summary_reference.fill`` renders those declarations into the tables that replace
the marker lines (``<!-- summary.json: sensors -->``) of ``docs/outputs.md``, so the page
lists exactly the keys a run writes.

As an MkDocs hook (``hooks: [docs/hooks/summary_reference.py]`` in ``mkdocs.yml``) the tables
are put in place as the page is read (:func:`on_page_markdown`): nothing is written into
``docs/``. ``python -m rangeproc.summary_reference FILE`` writes the filled page for a look
without MkDocs.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

#: The page with the markers, under docs/.
URI = "outputs.md"


def _fill(markdown: str) -> str:
    try:
        from rangeproc.summary_reference import fill
    except ImportError:                    # run from a checkout without rangeproc installed
        sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
        from rangeproc.summary_reference import fill
    return fill(markdown)


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """MkDocs ``on_page_markdown``: the outputs page with its summary.json tables."""
    return _fill(markdown) if page.file.src_uri == URI else markdown
