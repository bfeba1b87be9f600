"""The CSV dialect of a sensor file: its column separator and decimal mark, sniffed.

The data contract's CSV is comma-separated with decimal points. Files exported by a
spreadsheet in a European locale are semicolon-separated with decimal commas (``1,5``), and
some range systems write tab-separated text. Such a file is read as it is written when its
dialect is unambiguous (:func:`sniff_dialect`), and refused, naming the separator, when not:

1. **Separator**: the header row is split at each candidate (``,`` ``;`` tab, the contract's
   comma first); the first that yields every required column is the file's. The comma wins
   when it does, so a contract file never changes meaning. When neither semicolon nor tab
   is needed the file is comma-separated. When both a semicolon and a tab split would do,
   the file is ambiguous: :class:`~rangeproc.errors.DataError`. When none yields the
   required columns, the split with the most fields is reported with the missing column, so
   the message names the separator it was read with.
2. **Decimal mark** (only with a semicolon or tab separator, where a comma cannot separate
   columns): the numeric cells of the first :data:`SAMPLE_LINES` data lines are looked at in
   full. Numbers with a decimal comma (``1,5``, ``-0,25``, ``1,5e3``) and none with a decimal
   point: decimal commas. Both in one file: refused, naming a cell of each. Otherwise (points
   or integers only) decimal points.

A dialect other than the contract's is said once (a note, not a warning: the file is read as
written) by the reader that uses it.
"""
from __future__ import annotations

import csv
import itertools
import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path

from rangeproc.errors import DataError

#: Candidate column separators, the contract's first, with their names.
SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab"}
#: Data lines after the header whose cells decide the decimal mark.
SAMPLE_LINES = 2000

_DECIMAL_COMMA = re.compile(r"[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?")
_DECIMAL_POINT = re.compile(r"[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?")


@dataclass(frozen=True, slots=True)
class Dialect:
    """A CSV file's column separator and decimal mark ("." or ",")."""

    separator: str = ","
    decimal: str = "."

    @property
    def is_contract(self) -> bool:
        """The data contract's dialect: commas between columns, decimal points."""
        return self.separator == "," and self.decimal == "."

    def describe(self) -> str:
        """In words, e.g. ``semicolon-separated (';') with decimal commas``."""
        sep = SEPARATORS[self.separator]
        shown = "tab" if self.separator == "\t" else f"'{self.separator}'"
        text = f"{sep}-separated ({shown})" if sep != "tab" else "tab-separated"
        marks = "decimal commas" if self.decimal == "," else "decimal points"
        return f"{text} with {marks}"


def _shown(separator: str) -> str:
    return "tab" if separator == "\t" else f"'{separator}'"


def _split(line: str, separator: str) -> list[str]:
    try:
        return next(csv.reader([line], delimiter=separator), [])
    except csv.Error:
        return [line]


def _head(path: Path, n: int) -> list[str]:
    """The first ``n`` lines of ``path`` (UTF-8, a BOM dropped), without line ends."""
    try:
        with path.open("r", encoding="utf-8-sig", newline="") as fh:
            return [line.rstrip("\r\n") for line in itertools.islice(fh, n)]
    except UnicodeDecodeError:
        raise DataError(f"{path.name}: header row is not UTF-8 text") from None


def header_separator(name: str, header_line: str, required: Collection[str]) -> str:
    """The separator whose split of ``header_line`` holds every ``required`` column
    (whitespace around names ignored; the comma first); when none does, the one giving the
    most fields (the comma on a tie).

    Raises:
        DataError: both a semicolon and a tab split hold every required column.
    """
    fits = []
    widths = {}
    for sep in SEPARATORS:
        names = {h.strip() for h in _split(header_line, sep)}
        widths[sep] = len(names)
        if set(required) <= names:
            if sep == ",":
                return sep
            fits.append(sep)
    if len(fits) > 1:
        raise DataError(f"{name}: ambiguous column separator: the header row splits into the "
                        "required columns at " + " and at ".join(_shown(s) for s in fits)
                        + "; use one separator (the contract's is ',')")
    if fits:
        return fits[0]
    return max(SEPARATORS, key=lambda s: (widths[s], s == ","))


def _decimal(name: str, lines: list[str], separator: str, header: list[str],
             numeric: Collection[str]) -> str:
    """'.' or ',' from the numeric cells of the data ``lines`` (module docstring, step 2)."""
    columns = [(i, h.strip()) for i, h in enumerate(header) if h.strip() in numeric]
    comma = point = None
    for row, line in enumerate(lines, start=1):
        cells = _split(line, separator)
        for i, col in columns:
            cell = cells[i].strip() if i < len(cells) else ""
            if comma is None and _DECIMAL_COMMA.fullmatch(cell):
                comma = (row, col, cell)
            elif point is None and _DECIMAL_POINT.fullmatch(cell):
                point = (row, col, cell)
        if comma and point:
            raise DataError(
                f"{name}: {SEPARATORS[separator]}-separated ({_shown(separator)}) with both "
                f"decimal marks: row {comma[0]}, column '{comma[1]}': '{comma[2]}' and row "
                f"{point[0]}, column '{point[1]}': '{point[2]}'; write every number with one "
                "decimal mark")
    return "," if comma else "."


def sniff_dialect(path: Path, wanted: Mapping[str, bool], text: Collection[str]
                  ) -> tuple[Dialect, list[str]]:
    """The dialect of CSV file ``path`` (module docstring) and its header row split by it.

    wanted: contract column name -> required; text: the wanted columns that hold text (never
    numbers with a decimal mark).

    Raises:
        DataError: no header row, an ambiguous separator or mixed decimal marks, naming the
            file and the separator.
    """
    lines = _head(path, SAMPLE_LINES + 1)
    if not lines or not lines[0].strip():
        raise DataError(f"{path.name}: no header row (first line is empty)")
    required = [k for k, req in wanted.items() if req]
    separator = header_separator(path.name, lines[0], required)
    header = _split(lines[0], separator)
    if not any(h.strip() for h in header):
        raise DataError(f"{path.name}: no header row (first line is empty)")
    decimal = "."
    if separator != ",":
        numeric = {k for k in wanted if k not in text}
        decimal = _decimal(path.name, lines[1:], separator, header, numeric)
    return Dialect(separator, decimal), header
