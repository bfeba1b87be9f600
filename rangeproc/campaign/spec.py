"""What a campaign is: its sorties (one ``rangeproc run`` config each) and its output folder.

A campaign is given as either

* a TOML file::

      [output]
      dir = "campaign"               # campaign records; default "<file stem>_out" beside it

      [[sorties]]
      config = "flights/f101.toml"   # relative to the campaign file
      id = "F101"                    # optional; default the config's file stem

* or a folder: every ``*.toml`` in it (sorted by name) is a sortie, and the records go to
  ``<folder>/campaign``.

Sortie ids must be unique, and no two sorties may write the same ``[output].dir``; both are
one-line errors (exit 2) naming the file and key, before anything runs. A sortie's own
config is checked when it runs (a bad one fails that sortie only).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rangeproc.errors import ConfigError

try:
    import tomllib
except ModuleNotFoundError:                        # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]


@dataclass(frozen=True, slots=True)
class Sortie:
    """One flight of a campaign: ``id`` and its rangeproc config (absolute path)."""

    id: str
    config: Path


@dataclass(frozen=True, slots=True)
class Campaign:
    """The sorties, in the order given, and the folder for the campaign's own records."""

    source: Path
    sorties: tuple[Sortie, ...]
    out_dir: Path


def load_campaign(path: str | Path) -> Campaign:
    """Read a campaign file or folder (module docstring); ConfigError on anything unusable."""
    path = Path(path)
    if path.is_dir():
        configs = sorted(p for p in path.glob("*.toml") if p.is_file())
        if not configs:
            raise ConfigError(f"{path}: no *.toml sortie configs in this folder")
        sorties = [Sortie(p.stem, p.resolve()) for p in configs]
        campaign = Campaign(path.resolve(), tuple(sorties), (path / "campaign").resolve())
    elif path.is_file():
        campaign = _from_file(path)
    else:
        raise ConfigError(f"{path}: no such campaign file or folder")
    _check_unique(campaign)
    return campaign


def _from_file(path: Path) -> Campaign:
    name = path.name
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{name}: cannot read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{name}: not valid TOML ({exc})") from None
    for key in doc:
        if key not in ("output", "sorties"):
            raise ConfigError(f"{name}: {key}: unknown key (expected one of: output, sorties)")
    output = doc.get("output", {})
    if not isinstance(output, dict) or set(output) - {"dir"}:
        raise ConfigError(f"{name}: output: expected a table with only 'dir'")
    out = output.get("dir", f"{path.stem}_out")
    if not isinstance(out, str) or not out.strip():
        raise ConfigError(f"{name}: output.dir: expected a non-empty string")
    items = doc.get("sorties")
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{name}: sorties: expected a non-empty array of tables "
                          "([[sorties]] config = \"...\")")
    sorties = []
    for i, item in enumerate(items):
        key = f"sorties[{i}]"
        if not isinstance(item, dict) or set(item) - {"config", "id"}:
            raise ConfigError(f"{name}: {key}: expected a table with 'config' and optional 'id'")
        config = item.get("config")
        if not isinstance(config, str) or not config.strip():
            raise ConfigError(f"{name}: {key}.config: expected the path of a sortie config")
        config_path = (path.parent / config).resolve()
        if not config_path.is_file():
            raise ConfigError(f"{name}: {key}.config: {config_path} not found")
        ident = item.get("id", config_path.stem)
        if not isinstance(ident, str) or not ident.strip():
            raise ConfigError(f"{name}: {key}.id: expected a non-empty string")
        sorties.append(Sortie(ident, config_path))
    return Campaign(path.resolve(), tuple(sorties), (path.parent / out).resolve())


def _check_unique(campaign: Campaign) -> None:
    seen: dict[str, int] = {}
    for i, s in enumerate(campaign.sorties):
        if s.id in seen:
            raise ConfigError(f"{campaign.source.name}: sorties[{i}].id: duplicate sortie id "
                              f"'{s.id}' (also sorties[{seen[s.id]}])")
        seen[s.id] = i
    outputs: dict[Path, str] = {}
    for s in campaign.sorties:
        out = _output_dir(s.config)
        if out is not None and out in outputs:
            raise ConfigError(f"{s.config.name}: output.dir: {out} is also sortie "
                              f"'{outputs[out]}''s output folder")
        if out is not None:
            outputs[out] = s.id


def _output_dir(config: Path) -> Path | None:
    """A sortie config's resolved ``[output].dir`` (None when the file does not parse: that
    sortie then fails on its own when it runs)."""
    try:
        doc = tomllib.loads(config.read_text(encoding="utf-8"))
        out = doc.get("output", {}).get("dir", "out")
        return (config.parent / Path(out).expanduser()).resolve() if isinstance(out, str) \
            else None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, AttributeError):
        return None
