"""The documentation site keeps up with the code.

* every command, argument and option of the CLI has an entry in docs/cli.md, in its command's
  section;
* every column of fused.parquet, edits.parquet and association.parquet, and every key of
  summary.json and evaluation.json, is named in docs/outputs.md, in its file's section;
* the getting-started tutorial (docs/getting-started.md) runs as the page shows it: its config
  block is the shipped docs/tutorial/config.toml, the CSV heads it shows are the shipped files',
  and what the terminal prints for `rangeproc run`, `rangeproc evaluate`, the missing
  `time_offset` and the sigma in the wrong unit is what the page shows (numbers aside);
* the site builds with `mkdocs build --strict` (every warning an error), as `make docs` does.
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import click
import pandas as pd
import pytest
from click.testing import Result

from conftest import describe, invoke
from rangeproc.cli import main

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
TUTORIAL = DOCS / "tutorial"
GETTING_STARTED = DOCS / "getting-started.md"
#: The folder the tutorial's terminal output names (docs/getting-started.md).
DOC_FOLDER = "/home/you/tutorial"


# ---------------------------------------------------------------------------------- helpers
def sections(path: Path) -> dict[str, str]:
    """Heading line (level 2, without '## ') -> the text up to the next level-2 heading."""
    out: dict[str, str] = {}
    heading = ""
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            heading = line[3:].strip()
            out[heading] = ""
        elif heading:
            out[heading] += line + "\n"
    return out


def section_of(path: Path, name: str) -> str:
    """The level-2 section whose heading holds ``name`` in backticks (e.g. `rangeproc run`)."""
    found = [text for heading, text in sections(path).items() if f"`{name}`" in heading]
    assert len(found) == 1, f"{path.name}: no single section headed `{name}`"
    return found[0]


def items(text: str) -> list[str]:
    """The list items of a section (lines starting with '- '), continuation lines dropped."""
    return [line.strip() for line in text.splitlines() if line.lstrip().startswith("- ")]


def table_names(text: str) -> set[str]:
    """Every `name` in backticks within the first cell of a table row of ``text``."""
    names: set[str] = set()
    for line in text.splitlines():
        if line.startswith("|"):
            cells = line.split("|")
            if len(cells) > 2:
                names.update(re.findall(r"`([^`]+)`", cells[1]))
    return names


def backticked(text: str) -> set[str]:
    """Every `name` in backticks anywhere in ``text`` (and each of its dotted parts)."""
    return set(re.findall(r"`([^`]+)`", text))


def normalised(text: str) -> list[str]:
    """Lines with every number as '#' and runs of spaces as one, empty lines dropped: what a
    page's example must match (the figures may move when the estimation improves)."""
    out = []
    for line in text.splitlines():
        line = re.sub(r"\d+(?:[.,]\d+)*", "#", line)
        line = re.sub(r"\s+", " ", line).strip()
        if line:
            out.append(line)
    return out


# ----------------------------------------------------------------------- the command line
def cli_commands() -> list[tuple[str, click.Command]]:
    return sorted(main.commands.items())


def documented_in(section: str, flag: str) -> bool:
    """``flag`` (an option string or an argument's name) opens a list item of ``section``."""
    pattern = re.compile(r"^- (`[^`]*`, )*`" + re.escape(flag) + r"[` ]")
    return any(pattern.match(item) for item in items(section))


@pytest.mark.parametrize("name,command", cli_commands(), ids=[n for n, _ in cli_commands()])
def test_every_command_option_and_argument_is_documented(name: str,
                                                         command: click.Command) -> None:
    section = section_of(DOCS / "cli.md", f"rangeproc {name}")
    missing = []
    for param in command.params:
        if isinstance(param, click.Option):
            missing += [o for o in (*param.opts, *param.secondary_opts)
                        if not documented_in(section, o)]
        elif isinstance(param, click.Argument):
            if not documented_in(section, (param.metavar or param.name or "").upper()):
                missing.append(param.name.upper() if param.name else repr(param))
    assert not missing, (f"docs/cli.md, section `rangeproc {name}`: no list item for "
                         f"{', '.join(missing)}")


def test_the_global_options_are_documented() -> None:
    section = section_of(DOCS / "cli.md", "rangeproc")
    ctx = click.Context(main)
    params = [*main.params, main.get_help_option(ctx)]
    missing = [o for p in params if isinstance(p, click.Option)
               for o in (*p.opts, *p.secondary_opts) if not documented_in(section, o)]
    assert not missing, f"docs/cli.md, section `rangeproc`: no list item for {missing}"


def test_every_command_is_in_the_overview_table() -> None:
    text = (DOCS / "cli.md").read_text(encoding="utf-8")
    head = text.split("\n## ", 1)[0]
    missing = [n for n, _ in cli_commands() if f"`rangeproc {n}" not in head]
    assert not missing, f"docs/cli.md: commands missing from the table at the top: {missing}"


def test_every_exit_status_is_documented() -> None:
    import rangeproc.cli as cli

    section = sections(DOCS / "cli.md")["Exit statuses"]
    codes = {v for k, v in vars(cli).items() if k.startswith("EXIT_") and isinstance(v, int)}
    listed = {int(m) for m in re.findall(r"^\| (\d+) \|", section, flags=re.M)}
    assert codes <= listed, f"docs/cli.md, Exit statuses: missing {sorted(codes - listed)}"


# -------------------------------------------------------------------------- the outputs
def fused_columns() -> list[str]:
    from rangeproc.io.output import fused_table

    return list(fused_table([]).columns)


def test_every_fused_column_is_documented() -> None:
    names = table_names(section_of(DOCS / "outputs.md", "fused.parquet"))
    missing = [c for c in fused_columns() if c not in names]
    assert not missing, f"docs/outputs.md, fused.parquet: columns not in its table: {missing}"
    assert "p_<model>" in names                           # filter = "imm"'s columns


def test_every_edits_column_is_documented() -> None:
    from rangeproc.fusion.edit_table import EDIT_COLUMNS

    names = table_names(section_of(DOCS / "outputs.md", "edits.parquet"))
    missing = [c for c in EDIT_COLUMNS if c not in names]
    assert not missing, f"docs/outputs.md, edits.parquet: columns not in its table: {missing}"


def test_every_association_column_is_documented() -> None:
    from rangeproc.tracking.routing import ASSOCIATION_COLUMNS

    names = table_names(section_of(DOCS / "outputs.md", "association.parquet"))
    missing = [c for c in ASSOCIATION_COLUMNS if c not in names]
    assert not missing, (f"docs/outputs.md, association.parquet: columns not in its table: "
                         f"{missing}")


# ----------------------------------------------------------------------- the config keys
def test_every_config_key_is_documented() -> None:
    """Every settings field (the one declaration of a config key) has a meaning and a row in
    the generated config reference (docs/config.md); the per-table checks of types, defaults
    and the loader's key sets are in tests/test_docs_config.py."""
    from test_docs_config import declared_keys

    from rangeproc.config_reference import config_reference_markdown
    from rangeproc.keys import declaration_problems
    from rangeproc.settings import (Config, Geodetic, InitialState, OutputSettings,
                                    ProcessingSettings, SensorSettings, StationSettings,
                                    TargetSettings)

    assert declaration_problems(Config) == []
    reference = config_reference_markdown()
    rows = {line.split("|")[1].strip().strip("`") for line in reference.splitlines()
            if line.startswith("| `")}
    for cls in (OutputSettings, ProcessingSettings, SensorSettings, TargetSettings,
                InitialState, StationSettings, Geodetic):
        missing = sorted(declared_keys(cls) - rows)
        assert not missing, f"{cls.__name__}: keys not in docs/config.md: {missing}"


CONTRACT = DOCS / "contract.md"


def contract_keys() -> dict[str, set[str]]:
    """The config keys docs/contract.md names, by dotted table path ("sensors",
    "sensors.site", "processing"): the keys of its section 3 TOML example, and of its table
    of keys rangeproc adds (the key of ``key = ...``, or every backticked name of a
    section's row)."""
    import tomllib

    text = section_of_heading(CONTRACT, "3. Config (TOML)")
    block = re.search(r"```toml\n(.*?)```", text, re.S)
    assert block, "docs/contract.md section 3: no TOML example"
    found: dict[str, set[str]] = {}

    def walk(path: str, table: dict) -> None:
        for key, value in table.items():
            here = f"{path}.{key}" if path else key
            if path:
                found.setdefault(path, set()).add(key)
            for sub in (value if isinstance(value, list) else [value]):
                if isinstance(sub, dict):
                    walk(here, sub)

    walk("", tomllib.loads(block.group(1)))
    for line in text.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) < 4 or not cells[1].startswith("`["):
            continue
        path = cells[1].strip("`[]")
        keys = found.setdefault(path, set())
        if cells[2].startswith("`"):
            keys.add(cells[2].strip("`").split("=")[0].strip())
        else:
            keys.update(re.findall(r"`([a-z_]+)`", cells[2]))
    return found


def section_of_heading(path: Path, heading: str) -> str:
    """The level-2 section of ``path`` headed exactly ``heading``."""
    return sections(path)[heading]


def reference_paths(heading: str) -> list[str]:
    """``config_reference`` heading -> dotted table paths: "[[sensors]]" -> ["sensors"],
    "`[range] origin`, `[[sensors]] site`" -> ["range.origin", "sensors.site"]."""
    out = []
    for part in heading.replace("`", "").split(", "):
        table, *sub = part.split(" ")
        out.append(".".join([table.strip("[]"), *sub]))
    return out


def test_the_contract_page_names_every_key_of_the_reference() -> None:
    """docs/contract.md, the page a user writes a config from, names every key the config
    reference (the settings' declarations, ``config_reference.tables``) lists, in its
    table: a key added to the settings and left off the page fails here."""
    from rangeproc.config_reference import tables

    named = contract_keys()
    for heading, _, rows in tables():
        for path in reference_paths(heading):
            missing = sorted({r.key for r in rows} - named.get(path, set()))
            assert not missing, f"docs/contract.md, {path}: keys not named: {missing}"


def test_the_contract_key_check_sees_a_missing_key(monkeypatch, tmp_path: Path) -> None:
    """Negative control: the page without its rate_hz row fails the check."""
    page = tmp_path / "contract.md"
    page.write_text("\n".join(line for line in CONTRACT.read_text().splitlines()
                               if "`rate_hz = 20.0`" not in line))
    monkeypatch.setattr(sys.modules[__name__], "CONTRACT", page)
    with pytest.raises(AssertionError, match=r"sensors: keys not named: \['rate_hz'\]"):
        test_the_contract_page_names_every_key_of_the_reference()


def test_help_texts_name_files_that_exist() -> None:
    """A help text that points to a document (``docs/contract.md``, ``README.md``) points to
    one in the repository: `rangeproc run --help` named a DATA_CONTRACT.md that is not there.
    (Example paths such as ``flights/f101.toml`` are not pointers.)"""
    texts = [main.help or ""] + [c.help or "" for _, c in cli_commands()]
    texts += [p.help or "" for _, c in cli_commands() for p in c.params
              if isinstance(p, click.Option)]
    named = {m for t in texts for m in re.findall(r"[\w./-]+\.md\b", t)}
    assert "docs/contract.md" in named
    for name in named:
        assert (REPO / name).is_file(), f"a help text names {name}, not in the repository"


# ------------------------------------------------------------------------------ the README
README = REPO / "README.md"


def test_the_readme_is_short_and_undated() -> None:
    text = README.read_text()
    assert len(text.splitlines()) < 250
    for needle in ("stop ", "issue ", "seed 00"):
        assert needle not in text.lower(), needle
    assert not re.search(r"\b20[0-9]{2}-[01][0-9]-[0-3][0-9]\b(?!\")", text.replace(
        'time_offset = "2024-03-14"', "")), "a dated figure in the README"


def test_the_readme_config_is_the_tutorials() -> None:
    """The README's config runs on hand-made files: it is the tutorial's, which
    test_the_tutorial_runs_as_the_page_shows runs."""
    block = re.search(r"```toml\n(.*?)```", README.read_text(), re.S)
    assert block is not None
    shipped = (REPO / "docs" / "tutorial" / "config.toml").read_text()
    body = "\n".join(ln for ln in shipped.splitlines() if not ln.startswith("#")).strip()
    assert block.group(1).strip() == body


# ------------------------------------------------------------------------- the tutorial
@dataclass(frozen=True)
class Tutorial:
    """The page's marked blocks, and one run of the tutorial as the page says."""

    blocks: dict[str, str]        # marker -> the fenced block after it
    folder: Path                  # the user's folder: the CSVs and the page's config.toml
    run: Result
    evaluate: Result


def marked_blocks(path: Path) -> dict[str, str]:
    """``<!-- tutorial: NAME -->`` followed by a fenced block -> {NAME: the block's text}."""
    text = path.read_text(encoding="utf-8")
    found = re.findall(r"<!-- tutorial: ([^>]+?) -->\n```[a-z]*\n(.*?)```", text, flags=re.S)
    return {name: body for name, body in found}


@contextmanager
def working_directory(folder: Path) -> Iterator[None]:
    before = Path.cwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


def in_folder(result_text: str, folder: Path) -> str:
    return result_text.replace(str(folder), DOC_FOLDER)


@pytest.fixture(scope="module")
def tutorial(tmp_path_factory: pytest.TempPathFactory) -> Tutorial:
    blocks = marked_blocks(GETTING_STARTED)
    folder = tmp_path_factory.mktemp("tutorial")
    for csv in TUTORIAL.glob("*.csv"):
        shutil.copy(csv, folder / csv.name)
    (folder / "config.toml").write_text(blocks["config"], encoding="utf-8")
    with working_directory(folder):
        run = invoke(["run", "config.toml"])
        evaluate = invoke(["evaluate", "out", "truth.csv"]) if run.exit_code == 0 else run
    return Tutorial(blocks, folder, run, evaluate)


def test_the_page_shows_the_shipped_files() -> None:
    blocks = marked_blocks(GETTING_STARTED)
    assert blocks["config"] == (TUTORIAL / "config.toml").read_text(encoding="utf-8")
    for name in ("radar.csv", "gps.csv"):
        shown = blocks[f"file {name}"].splitlines()
        assert shown == (TUTORIAL / name).read_text().splitlines()[:len(shown)], name
    assert sum(p.stat().st_size for p in TUTORIAL.iterdir()) < 200_000


def test_the_tutorial_runs_as_the_page_shows(tutorial: Tutorial) -> None:
    run = tutorial.run
    assert run.exit_code == 0, describe(run)
    assert "WARNING" not in run.stderr, describe(run)
    assert (normalised(in_folder(run.stdout, tutorial.folder))
            == normalised(tutorial.blocks["run-output"])), describe(run)
    out = tutorial.folder / "out"
    fused = pd.read_parquet(out / "fused.parquet")
    assert list(fused["target_id"].unique()) == ["T1"]
    assert 850 <= len(fused) <= 910                      # 90 s at 10 Hz
    worst = fused[["sigma_e", "sigma_n", "sigma_u"]].max(axis=1)
    assert 0.0 < worst.median() < 3.0 and worst.max() < 10.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sensors"]["RADAR"]["n_edited"].get("pre-edit", 0) >= 2   # the wild ranges
    assert summary["warnings"] == []
    assert (out / "report" / "index.html").is_file()


def test_the_tutorial_evaluates_as_the_page_shows(tutorial: Tutorial) -> None:
    ev = tutorial.evaluate
    assert ev.exit_code == 0, describe(ev)
    assert (normalised(in_folder(ev.stdout, tutorial.folder))
            == normalised(tutorial.blocks["evaluate-output"])), describe(ev)
    metrics = json.loads((tutorial.folder / "out" / "evaluation.json").read_text())
    t1 = metrics["targets"]["T1"]
    assert t1["pos_rmse"] < 3.0 and min(t1["inside_3sigma_enu"]) > 0.95


def test_the_tutorial_error_is_the_one_the_page_shows(tutorial: Tutorial,
                                                      tmp_path: Path) -> None:
    for csv in TUTORIAL.glob("*.csv"):
        shutil.copy(csv, tmp_path / csv.name)
    config = "".join(line for line in tutorial.blocks["config"].splitlines(keepends=True)
                     if not line.startswith("time_offset"))
    assert config != tutorial.blocks["config"]
    (tmp_path / "config.toml").write_text(config)
    result = invoke(["run", tmp_path / "config.toml"])
    assert result.exit_code == 2, describe(result)
    assert (normalised(result.stderr)
            == normalised(tutorial.blocks["error-without-time-offset"])), describe(result)
    assert not (tmp_path / "out" / "fused.parquet").exists()


def test_the_tutorial_warning_is_the_one_the_page_shows(tutorial: Tutorial,
                                                        tmp_path: Path) -> None:
    text = GETTING_STARTED.read_text(encoding="utf-8")
    wrong = re.search(r"```toml\n(sigma = [^\n]*)\n```", text)
    assert wrong, "docs/getting-started.md: the sigma-in-the-wrong-unit example is gone"
    for csv in TUTORIAL.glob("*.csv"):
        shutil.copy(csv, tmp_path / csv.name)
    radar_sigma = re.search(r"^sigma = \{ range.*$", tutorial.blocks["config"], flags=re.M)
    assert radar_sigma
    config = tutorial.blocks["config"].replace(radar_sigma.group(0), wrong.group(1))
    (tmp_path / "config.toml").write_text(config)
    result = invoke(["run", "--quiet", tmp_path / "config.toml"])
    assert result.exit_code == 0, describe(result)
    assert (normalised(result.stderr)
            == normalised(tutorial.blocks["warning-sigma-unit"])), describe(result)


def test_every_summary_and_evaluation_key_is_documented(tutorial: Tutorial) -> None:
    from rangeproc.summary_reference import fill
    from rangeproc.summary_types import disagreements

    assert tutorial.evaluate.exit_code == 0, describe(tutorial.evaluate)
    out = tutorial.folder / "out"
    summary = json.loads((out / "summary.json").read_text())
    evaluation = json.loads((out / "evaluation.json").read_text())
    # the page as the docs build serves it: the tables generated from the declaration
    text = fill(section_of(DOCS / "outputs.md", "summary.json"))
    assert list(disagreements(summary)) == []                  # the run writes what is declared
    named = backticked(text) | {p for n in backticked(text) for p in re.split(r"[.,\s]+", n)}
    keys = {"summary.json": set(summary),
            "summary.json sensors.<id>": {k for s in summary["sensors"].values() for k in s},
            "summary.json targets.<id>": {k for t in summary["targets"].values() for k in t},
            "summary.json association": set(summary["association"]),
            "summary.json time_scale": set(summary["time_scale"])}
    missing = {where: sorted(k - named) for where, k in keys.items() if k - named}
    ev_text = sections(DOCS / "outputs.md")["Evaluation files"]
    ev_named = backticked(ev_text)
    ev_keys = set(evaluation) | {k for t in evaluation["targets"].values() for k in t}
    if ev_keys - ev_named:
        missing["evaluation.json"] = sorted(ev_keys - ev_named)
    assert not missing, f"docs/outputs.md does not name: {missing}"


# ------------------------------------------------------------------------------ the site
def test_the_site_builds_without_a_warning(tmp_path: Path) -> None:
    if importlib.util.find_spec("mkdocs") is None or \
            importlib.util.find_spec("material") is None:
        pytest.skip("mkdocs and mkdocs-material are not installed (pip install -e '.[docs]')")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "WARNING" not in done.stderr, done.stderr
    for page in ("index", "getting-started", "contract", "cli", "outputs", "changelog"):
        assert (tmp_path / "site" / f"{page}.html").is_file(), page
    changelog = (tmp_path / "site" / "changelog.html").read_text(encoding="utf-8")
    assert "Unreleased" in changelog and "--8&lt;--" not in changelog
