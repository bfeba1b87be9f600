"""MkDocs hook: the nav sections whose pages are written elsewhere.

The Config reference (``config.md``, generated from the settings declarations), the Methods
pages (``methods/``) and the Validation pages (``validation/``) are added to the nav, before
the Changelog, when they exist and ``mkdocs.yml``'s nav does not list them already. A folder's
``index.md`` comes first, then its other pages by file name. Listing them in ``mkdocs.yml``
(in the order wanted) overrides this.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

#: (nav title, page or folder under docs/), in nav order.
SECTIONS = (("Config reference", "config.md"), ("Methods", "methods"),
            ("Validation", "validation"))


def _paths(item: Any) -> list[str]:
    """Every page path a nav item names."""
    if isinstance(item, str):
        return [item]
    if isinstance(item, dict):
        return [p for value in item.values() for p in _paths(value)]
    if isinstance(item, list):
        return [p for value in item for p in _paths(value)]
    return []


def _folder_pages(docs: Path, folder: str) -> list[Any]:
    pages = sorted((docs / folder).glob("*.md"), key=lambda p: (p.name != "index.md", p.name))
    return [f"{folder}/{p.name}" for p in pages]


def on_config(config: Any) -> Any:
    docs = Path(config["docs_dir"])
    nav = config["nav"]
    if nav is None:                            # no nav in mkdocs.yml: MkDocs lists every page
        return config
    listed = _paths(nav)
    at = next((i for i, item in enumerate(nav) if "changelog.md" in _paths(item)), len(nav))
    for title, target in SECTIONS:
        if any(p == target or p.startswith(target + "/") for p in listed):
            continue
        if target.endswith(".md"):
            entry = {title: target} if (docs / target).is_file() else None
        else:
            pages = _folder_pages(docs, target)
            entry = {title: pages} if pages else None
        if entry is not None:
            nav.insert(at, entry)
            at += 1
    return config
