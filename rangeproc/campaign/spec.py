"""What a campaign is: its sorties (one ``rangeproc run`` config each) and its output folder.

A campaign is given as either

* a TOML file::

      [output]
      dir = "campaign"               # campaign records; default "<file stem>_out" beside it

      [[sorties]]
      config = "flights/f101.toml"   # relative to the campaign file
      id = "F101"                    # optional; default the config's file stem

* or a folder: every ``*.toml`` in it is a sortie (its id the file stem), and so is every
  immediate sub-folder holding a ``config.toml`` (its id the sub-folder's name), sorted by
  id; each sortie writes where its config's ``[output].dir`` says, and the campaign's
  records go to ``<folder>/campaign``.

Sortie ids must be unique, and no two sorties may write the same ``[output].dir``; both are
one-line errors (exit 2) naming the file and key, before anything runs. A sortie's own
config is checked when it runs (a bad one fails that sortie only).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rangeproc.config_checks import ValueChecks, toml_syntax_error
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
        sorties = sorted(_folder_sorties(path), key=lambda s: s.id)
        if not sorties:
            raise ConfigError(f"{path}: no sortie configs in this folder (*.toml, or "
                              "sub-folders each holding a config.toml)")
        campaign = Campaign(path.resolve(), tuple(sorties), (path / "campaign").resolve())
    elif path.is_file():
        campaign = _from_file(path)
    else:
        raise ConfigError(f"{path}: no such campaign file or folder")
    _check_unique(campaign)
    return campaign


def _folder_sorties(path: Path) -> list[Sortie]:
    """A campaign folder's sorties: its ``*.toml`` files (id: the file stem) and its
    immediate sub-folders holding a ``config.toml`` (id: the sub-folder's name)."""
    sorties = [Sortie(p.stem, p.resolve()) for p in path.glob("*.toml") if p.is_file()]
    sorties += [Sortie(d.name, (d / "config.toml").resolve()) for d in path.iterdir()
                if d.is_dir() and (d / "config.toml").is_file()]
    return sorties


def _from_file(path: Path) -> Campaign:
    check = ValueChecks(path.name)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise check.error("", f"cannot read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise toml_syntax_error(path.name, exc) from None
    check.table(doc, "", ("output", "sorties"))
    output = check.table(doc.get("output", {}), "output", ("dir",))
    out = check.string(output.get("dir", f"{path.stem}_out"), "output.dir")
    items = doc.get("sorties")
    if not isinstance(items, list) or not items:
        raise check.error("sorties", "expected a non-empty array of tables "
                                     "([[sorties]] config = \"...\")")
    sorties = []
    for i, item in enumerate(items):
        key = f"sorties[{i}]"
        t = check.table(item, key, ("config", "id"))
        config = check.string(check.required(t, "config", key), f"{key}.config")
        config_path = (path.parent / config).resolve()
        if not config_path.is_file():
            raise check.error(f"{key}.config", f"{config_path} not found")
        sorties.append(Sortie(check.string(t.get("id", config_path.stem), f"{key}.id"),
                              config_path))
    return Campaign(path.resolve(), tuple(sorties), (path.parent / out).resolve())


def _check_unique(campaign: Campaign) -> None:
    ValueChecks(campaign.source.name).unique_ids([s.id for s in campaign.sorties],
                                                 lambda i: f"sorties[{i}].id", "sortie")
    outputs: dict[Path, str] = {}
    for s in campaign.sorties:
        out = _output_dir(s.config)
        if out is not None and out in outputs:
            raise ConfigError(f"{s.config.name}: output.dir: {out} is also sortie "
                              f"'{outputs[out]}''s output folder")
        if out is not None:
            outputs[out] = s.id


def _output_dir(config: Path) -> Path | None:
    """A sortie config's resolved ``[output].dir`` (``rangeproc.config``); None when the
    config is unusable: that sortie then fails on its own when it runs."""
    from rangeproc.config import load_config

    try:
        return load_config(config).output.dir
    except ConfigError:
        return None
