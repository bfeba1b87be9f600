"""The outputs page's tables of ``summary.json``, generated from the declaration.

Each section of ``summary.json`` is declared once, as a ``TypedDict`` of
``rangeproc.summary_types`` whose keys carry what they hold; this module renders those
declarations into the page's Markdown tables, so the page cannot list a key the run does not
write or miss one it does. ``docs/outputs.md`` holds one marker line per table
(:func:`marker`, e.g. ``<!-- summary.json: sensors -->``); the docs build puts the table in
its place through the MkDocs hook ``docs/hooks/summary_reference.py``.
"""
from __future__ import annotations

import re
from collections.abc import Iterator

from rangeproc.summary_types import DOCUMENTED, Declared, declared_keys

#: A marker line of the outputs page: the name of a section of ``summary_types.DOCUMENTED``.
MARKER = re.compile(r"^<!-- summary\.json: ([a-z_]+) -->$", re.MULTILINE)


def marker(section: str) -> str:
    """The line of the outputs page that the table of ``section`` replaces."""
    return f"<!-- summary.json: {section} -->"


def _groups(keys: tuple[Declared, ...]) -> Iterator[tuple[list[str], str]]:
    """(key names, what) per row: consecutive keys sharing one ``Doc`` share a row."""
    names: list[str] = []
    for i, d in enumerate(keys):
        if d.doc is None:
            raise ValueError(f"summary.json key {d.name!r} is declared without a Doc")
        names.append(d.name)
        if i + 1 == len(keys) or keys[i + 1].doc is not d.doc:
            yield names, d.doc.what
            names = []


def section_table(section: str) -> str:
    """The Markdown table (``| key | what |``) of a documented section, its keys in the
    order of the declaration."""
    record = dict(DOCUMENTED)[section]
    lines = ["| key | what |", "|---|---|"]
    lines += [f"| {', '.join(f'`{n}`' for n in names)} | {what.replace('|', chr(92) + '|')} |"
              for names, what in _groups(declared_keys(record))]
    return "\n".join(lines)


def fill(markdown: str) -> str:
    """``markdown`` with every marker line replaced by its section's table; a marker naming
    no documented section is a ValueError."""
    known = dict(DOCUMENTED)

    def table(m: re.Match[str]) -> str:
        if m.group(1) not in known:
            raise ValueError(f"{m.group(0)}: no such summary.json section "
                             f"(declared: {', '.join(known)})")
        return section_table(m.group(1))
    return MARKER.sub(table, markdown)
