"""The optional [processing] section: defaults, the filter choice, and its errors."""
from pathlib import Path

import pytest

from rangeproc.config import ProcessingSettings, load_config
from rangeproc.errors import ConfigError

BASE = """
[range]
origin = { lat = 34.9, lon = -117.9, height = 700.0 }

[[sensors]]
id = "G1"
kind = "gps"
file = "G1.csv"
"""


def _write(tmp_path: Path, extra: str) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(BASE + extra)
    return path


def test_defaults_without_processing_section(tmp_path):
    cfg = load_config(_write(tmp_path, ""))
    assert cfg.processing == ProcessingSettings()
    assert cfg.processing.filter == "auto"


def test_ukf_selected(tmp_path):
    cfg = load_config(_write(tmp_path, '\n[processing]\nfilter = "ukf"\nnoise_passes = 1\n'))
    assert cfg.processing.filter == "ukf"
    assert cfg.processing.noise_passes == 1


def test_stukf_keys(tmp_path):
    cfg = load_config(_write(tmp_path, '\n[processing]\nfilter = "stukf"\nstukf_forgetting = 0.9\n'
                                       "stukf_weakening = 4.0\nstukf_ratios = [1, 1, 2.5]\n"))
    p = cfg.processing
    assert (p.filter, p.stukf_forgetting, p.stukf_weakening) == ("stukf", 0.9, 4.0)
    assert p.stukf_ratios == (1.0, 1.0, 2.5)


def test_imm_keys(tmp_path):
    cfg = load_config(_write(tmp_path, '\n[processing]\nfilter = "imm"\nimm_models = ["ca", "ct"]\n'
                                       "imm_sojourn = 4.0\n"))
    assert cfg.processing.imm_models == ("ca", "ct") and cfg.processing.imm_sojourn == 4.0
    assert ProcessingSettings().imm_models == ("cv", "ca", "ct")


@pytest.mark.parametrize("extra, key", [
    ('\n[processing]\nfilter = "pf"\n', "processing.filter"),
    ('\n[processing]\nimm_models = ["ca", "xx"]\n', "processing.imm_models"),
    ('\n[processing]\nimm_models = []\n', "processing.imm_models"),
    ('\n[processing]\nimm_models = ["ca", "ca"]\n', "processing.imm_models"),
    ("\n[processing]\nimm_sojourn = 0.0\n", "processing.imm_sojourn"),
    ("\n[processing]\nstukf_weakening = 0.5\n", "processing.stukf_weakening"),
    ("\n[processing]\nstukf_forgetting = 1.5\n", "processing.stukf_forgetting"),
    ("\n[processing]\nstukf_ratios = [1, 2]\n", "processing.stukf_ratios"),
    ("\n[processing]\nstukf_ratios = [1, 0.5, 1]\n", "processing.stukf_ratios[1]"),
    ("\n[processing]\nfilter = 3\n", "processing.filter"),
    ("\n[processing]\nfiltre = \"ukf\"\n", "filtre"),
])
def test_processing_errors_name_the_key(tmp_path, extra, key):
    with pytest.raises(ConfigError) as exc:
        load_config(_write(tmp_path, extra))
    msg = str(exc.value)
    assert "c.toml" in msg and key in msg and "\n" not in msg



def test_hampel_keys_are_read_and_checked(tmp_path):
    cfg = load_config(_write(tmp_path, "\n[processing]\nhampel_window = 0\n"
                                       "hampel_threshold = 4.5\n"))
    assert (cfg.processing.hampel_window, cfg.processing.hampel_threshold) == (0, 4.5)
    with pytest.raises(ConfigError, match="processing.hampel_window"):
        load_config(_write(tmp_path, "\n[processing]\nhampel_window = 2.5\n"))
    with pytest.raises(ConfigError, match="processing.hampel_threshold"):
        load_config(_write(tmp_path, "\n[processing]\nhampel_threshold = 0.1\n"))
