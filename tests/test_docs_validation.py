"""The validation pages' generator (docs/hooks/validation.py): every measurement file present
is rendered into tables holding its numbers, a missing one says how to measure it."""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
HOOK = REPO / "docs" / "hooks" / "validation.py"
MEASUREMENTS = REPO / "docs" / "measurements"

spec = importlib.util.spec_from_file_location("docs_validation_hook", HOOK)
validation = importlib.util.module_from_spec(spec)
spec.loader.exec_module(validation)

META = {"machine": {"cpu": "Test CPU 9000", "cores": 2, "cores_usable": 2, "memory_gib": 8.0,
                    "os": "Testix 1", "python": "3.11.7", "numpy": "2.0.0", "numba": "0.60.0",
                    "load_average": [0.5, 0.4, 0.3]},
        "date": "2026-01-02T03:04:05+00:00", "git_commit": "abc1234",
        "command": "python bench/x.py --seeds 1"}


def page(uri: str, folder: Path) -> str:
    return validation.render_page(uri, folder)


# ------------------------------------------------------------- numbers expected per page
def accuracy_numbers(data) -> list[str]:
    rows = validation.rows_of(data)
    return ([f"{r['pos_rmse']:.3f}" for r in rows] + [f"{r['nees_pos_mean']:.2f}" for r in rows]
            + [f"{min(r['inside_3sigma_enu']):.3f}" for r in rows])


def registration_numbers(data) -> list[str]:
    out = []
    for s in validation.rows_of(data):
        out += [f"{t['in_sigmas']:.2f}" for t in s["terms"] if t.get("in_sigmas") is not None]
        out += [f"{r['rmse']:.3f}" for r in s["runs"].values()]
    return out


def multi_numbers(data) -> list[str]:
    return [f"{r['rmse']:.2f}" for r in validation.rows_of(data) if r.get("rmse") is not None]


def autoferry_numbers(data) -> list[str]:
    out = [f"{s['gospa_mean']:.2f}" for s in data["acceptance"]["per_tracker"].values()
           if s.get("gospa_mean") is not None]
    out += [f"{v:.1f}" for s in data["acceptance"]["per_tracker"].values()
            for v in (s.get("gospa_rms") or {}).values() if v is not None]
    for r in data["results"]:
        sc = r["rangeproc_contract"].get("score")
        if sc:
            out.append(f"{sc['gospa_mean']:.1f}")
            out += [f"{b['best_match_rmse']:.1f}" for b in sc["boats"].values()
                    if b.get("best_match_rmse") is not None]
    return out


def bench_numbers(data) -> list[str]:
    out = []
    if "kernel" in data:
        k = data["kernel"]
        out += [f"{k['us_per_meas']['rangeproc']:.2f}", f"{k['ratio_filterpy']:.1f}",
                f"{k['ukf']['us_per_meas']['rangeproc']:.2f}"]
        out += [f"{f['us_per_meas']:.2f}" for f in k.get("filters", {}).values()]
    for key in ("pipeline", "multi"):
        if key in data:
            out += [f"{data[key]['process_wall_s']:.1f}", f"{data[key]['total_rows']:,}"]
    return out


NUMBERS = {"accuracy.json": accuracy_numbers, "registration.json": registration_numbers,
           "multi.json": multi_numbers, "autoferry.json": autoferry_numbers,
           "bench.json": bench_numbers}
URI = {file: uri for uri, (_, file, _, _) in validation.PAGES.items()}


# --------------------------------------------------------------- the committed measurements
@pytest.mark.parametrize("file", sorted(NUMBERS))
def test_every_measurement_present_is_rendered_with_its_numbers(file: str) -> None:
    path = MEASUREMENTS / file
    if not path.exists():
        pytest.skip(f"docs/measurements/{file} not measured in this checkout")
    data = json.loads(path.read_text())
    text = page(URI[file], MEASUREMENTS)
    assert "Not measured yet" not in text
    assert "| ---" in text                                   # a table
    numbers = NUMBERS[file](data)
    assert numbers
    missing = [n for n in numbers if n not in text]
    assert not missing, f"{file}: numbers not on the page: {missing[:10]}"
    meta = validation.meta_of(data)
    if meta is not None:
        assert meta["date"].replace("T", " ") in text


# ------------------------------------------------------------------------ fixtures
def write(folder: Path, name: str, data) -> None:
    (folder / name).write_text(json.dumps(data))


def test_missing_measurements_say_how_to_measure_them(tmp_path: Path) -> None:
    pages = validation.render_all(tmp_path)
    assert set(pages) == {"validation/index.md", *validation.PAGES}
    for uri, (title, file, target, _) in validation.PAGES.items():
        assert pages[uri].startswith(f"# {title}")
        assert f"Not measured yet: run `make {target}`" in pages[uri]
        assert file in pages[uri]
    assert pages["validation/index.md"].count("not measured yet") == len(validation.PAGES)


def test_an_unreadable_file_is_named_not_fatal(tmp_path: Path) -> None:
    (tmp_path / "accuracy.json").write_text("{not json")
    text = page("validation/accuracy.md", tmp_path)
    assert "could not be read" in text and "make accuracy" in text


def test_accuracy_with_meta(tmp_path: Path) -> None:
    rows = [{"seed": s, "filter": f, "case": c, "sigma_factor": 1.0, "elapsed_s": 4.2,
             "pos_rmse": 0.1234 * s + (0.01 if f == "imm" else 0.0), "pos_p95": 0.2,
             "vel_rmse": 0.05, "vel_p95": 0.1, "inside_3sigma_enu": [1.0, 0.9876, 1.0],
             "nees_pos_mean": 2.718}
            for s in (1, 2) for f in ("ekf", "imm") for c in ("full", "no MISTRAM/theodolite")]
    write(tmp_path, "accuracy.json", {"meta": META, "rows": rows})
    text = page("validation/accuracy.md", tmp_path)
    for n in ("0.123", "0.247", "2.72", "0.988", "Test CPU 9000", "2026-01-02 03:04:05",
              "abc1234", "python bench/x.py --seeds 1", "load average 0.50"):
        assert n in text, n
    assert "## Every filter against the EKF" in text and "1.08×" in text   # 0.1334 / 0.1234


def test_list_without_meta_renders_with_machine_unknown(tmp_path: Path) -> None:
    rows = [{"kind": "crossing", "seed": 1, "object": "T1", "match": "T1", "rmse": 1.2345,
             "oracle_rmse": 1.2345, "ratio": 1.0, "coverage": 1.0, "coverage_observed": 1.0,
             "cutoff_scaled": 50.0, "coverage_scaled": 1.0, "swaps": 0, "fragments": 0,
             "gospa_mean": 3.5, "run_s": 4.0},
            {"kind": "mixed", "seed": 2, "object": "U1", "match": "O2", "rmse": 37.54,
             "oracle_rmse": 10.95, "ratio": 3.428, "coverage": 0.961, "coverage_observed": 0.968,
             "cutoff_scaled": 50.0, "coverage_scaled": 0.968, "swaps": 1, "fragments": 1,
             "gospa_mean": 14.6, "run_s": 9.0},
            {"kind": "mixed", "seed": 3, "error": "boom"}]
    write(tmp_path, "multi.json", rows)                       # the old form: a bare list
    text = page("validation/several-objects.md", tmp_path)
    assert "machine and date unknown" in text
    for n in ("1.23", "37.54", "10.95", "3.43×", "boom"):
        assert n in text, n
    assert "## Objects outside the acceptance" in text
    outside = text.split("## Objects outside the acceptance")[1].split("## Every object")[0]
    assert "37.54" in outside and "1.23" not in outside
    index = validation.render_index(tmp_path)
    assert "unknown" in index


def test_registration_and_unobservable_terms(tmp_path: Path) -> None:
    seed = {"seed": 1, "terms": [
        {"sensor": "R1", "name": "range", "true": 15.0, "estimate": 15.17, "sigma": 0.1666,
         "in_sigmas": 1.0178, "share": 0.0113, "reason": ""},
        {"sensor": "S1", "name": "azimuth", "true": 0.001, "estimate": None, "sigma": None,
         "in_sigmas": None, "share": None, "reason": "not separable from mount_yaw"}],
        "runs": {k: {"rmse": 0.2485, "in3": 1.0, "nees": 3.51} for k in
                 ("faults_cal", "faults_nocal", "clean_cal", "clean_nocal")}}
    write(tmp_path, "registration.json", {"meta": META, "rows": [seed]})
    text = page("validation/registration.md", tmp_path)
    for n in ("1.02", "15.17", "1.1 %", "0.248 / 1.000 / 3.51", "not separable from mount_yaw",
              "1.00×"):
        assert n in text, n


def _score(gospa: float, rmse: float) -> dict:
    boat = {"best_match": "O1", "best_match_rmse": rmse, "assigned_rmse": rmse,
            "coverage": 0.93, "swaps": 1, "fragmentation": 0, "n_epochs": 500}
    return {"boats": {"B1": boat, "B2": dict(boat, best_match_rmse=rmse + 1)},
            "gospa_mean": gospa}


def test_autoferry_and_a_jpda_that_did_not_finish(tmp_path: Path) -> None:
    result = {"scenario": 2,
              "rangeproc_contract": {"ok": True, "score": _score(11.34, 3.14)},
              "rangeproc_no_cameras": {"ok": True, "score": _score(10.9, 3.0)},
              "stonesoup": {"finished": True, "score": _score(25.5, 5.0)},
              "stonesoup_jpda": {"finished": False, "timed_out": True}}
    acc = {"per_scenario": [{"scenario": 2, "baselines_compared": ["stonesoup"],
                             "values": {"gospa_mean": {"rangeproc": 11.34, "stonesoup": 25.5},
                                        "coverage_mean": {"rangeproc": 0.93, "stonesoup": 0.9},
                                        "best_match_rmse_mean": {"rangeproc": 3.64,
                                                                 "stonesoup": 5.5}},
                             "gospa": True, "coverage": True, "rmse": True, "all": True}],
           "n_all_three": 1, "n_scenarios": 1,
           "per_tracker": {"rangeproc": {"label": "rangeproc (cameras)", "n_scenarios": 1,
                                         "gospa_mean": 11.34, "coverage_mean": 0.93,
                                         "best_match_rmse_median": 3.64,
                                         "n_rmse_above_30m": 0, "swaps_total": 2}}}
    write(tmp_path, "autoferry.json", {"meta": META, "cutoff_m": 20.0, "results": [result],
                                       "acceptance": acc})
    text = page("validation/real-data.md", tmp_path)
    for n in ("3.1", "11.3", "25.5", "timed out", "11.34", "3.64", "All three hold in 1 of 1"):
        assert n in text, n


def test_autoferry_with_smoothed_baselines_and_acceptance_lines(tmp_path: Path) -> None:
    """The page from what bench/autoferry.py writes now: the RTS-smoothed baselines' columns,
    issue 41's acceptance lines (measured, target, met), the GOSPA RMS per environment with
    the published figures."""
    sys.path.insert(0, str(REPO / "bench"))
    import autoferry as bench

    def sc(gospa: float, rmse: float, cov: float, rms: float) -> dict:
        return dict(_score(gospa, rmse), gospa_rms=rms, n_epochs=400,
                    boats={b: dict(m, coverage=cov)
                           for b, m in _score(gospa, rmse)["boats"].items()})
    results = []
    for n in (2, 13):
        base = {"finished": True, "score": sc(26.5, 9.25, 0.87, 31.5)}
        results.append({"scenario": n,
                        "rangeproc_contract": {"ok": True, "score": sc(12.75, 4.5, 0.95, 13.2)},
                        "rangeproc_no_cameras": {"ok": True, "score": sc(13.0, 5.0, 0.9, 14.0)},
                        "stonesoup": dict(base), "stonesoup_rts": {
                            "finished": True, "score": sc(21.5, 7.7, 0.88, 27.3)},
                        "stonesoup_jpda": {"finished": False, "timed_out": True},
                        "stonesoup_jpda_rts": {"finished": False, "timed_out": True}})
    acc = bench.acceptance(results)
    write(tmp_path, "autoferry.json", {"meta": META, "cutoff_m": 20.0, "results": results,
                                       "acceptance": acc})
    text = page("validation/real-data.md", tmp_path)
    for n in ("Stone Soup GNN+RTS RMSE", "Stone Soup JPDA+RTS RMSE", "timed out", "7.7",
              "21.5", "GOSPA RMS 2-6 (m)", "GOSPA RMS 13-22 (m)", "13.2", "27.3", "20.4",
              "31.0", "Ocean Engineering", "mean coverage (boat-scenarios)", ">= 0.90",
              "0.950", "swaps no more than the best baseline", "GNN / JPDA / GNN+RTS / JPDA+RTS",
              "GOSPA and RMSE", "Coverage per boat-scenario"):
        assert n in text, n
    assert "All three hold" not in text


def test_speed_from_an_old_results_file_with_machine_block(tmp_path: Path) -> None:
    agree = {"smoothed_pos_rel": 3.3e-15}
    data = {"machine": {"processor": "Old CPU", "cpu_count": 4, "platform": "Linux-x",
                        "python": "3.11", "numpy": "2", "numba": "0.6",
                        "timestamp": "2026-11-23T10:00:00+00:00", "git_commit": "def5678"},
            "params": {"quick": True, "duration_s": 300.0, "multi_duration_s": 300.0},
            "kernel": {"rows": 5000, "stonesoup_rows": 500, "dt_s": 0.05,
                       "us_per_meas": {"rangeproc": 2.345, "filterpy": 33.8, "stonesoup": 542.0,
                                       "stonesoup_stock": 1067.0},
                       "ratio_filterpy": 14.41, "ratio_stonesoup": 231.1,
                       "ratio_stonesoup_stock": 455.0,
                       "agreement": {"filterpy": agree, "stonesoup": agree,
                                     "stonesoup_stock": agree},
                       "ukf": {"rows": 5000, "stonesoup_rows": 500,
                               "us_per_meas": {"rangeproc": 3.987, "filterpy": 330.0,
                                               "stonesoup": 1382.0},
                               "ratio_filterpy": 82.8, "ratio_stonesoup": 346.6,
                               "agreement": {"filterpy_redraw": agree, "stonesoup": agree}},
                       "filters": {"imm": {"us_per_meas": 9.876, "ratio_to_base": 4.2,
                                           "ratio_to_ekf": 4.2}}},
            "pipeline": {"duration_s": 300.0, "total_rows": 123456, "process_wall_s": 12.34,
                         "run_s": 10.0, "us_per_meas_wall": 99.9, "us_per_meas_run": 81.0,
                         "peak_rss_bytes": 1.5e9, "stages_s": {"read": 0.5, "fuse": 6.25}}}
    write(tmp_path, "bench.json", data)
    text = page("validation/speed.md", tmp_path)
    for n in ("Old CPU", "2026-11-23 10:00:00", "def5678", "2.35", "14.4×", "3.99", "9.88",
              "12.3", "123,456", "6.25", "CI-sized run"):
        assert n in text, n


def test_mkdocs_build_serves_the_pages_without_writing_docs(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs")
    from mkdocs.commands.build import build
    from mkdocs.config import load_config
    docs = tmp_path / "docs"
    (docs / "measurements").mkdir(parents=True)
    (docs / "index.md").write_text("# Home\n")
    (docs / "methods").mkdir()
    (docs / "methods" / "index.md").write_text("# Methods\n")       # the index links here
    rows = [{"seed": 1, "filter": "ekf", "case": "full", "sigma_factor": 1.0, "elapsed_s": 1.0,
             "pos_rmse": 0.4321, "pos_p95": 0.9, "vel_rmse": 0.1, "vel_p95": 0.2,
             "inside_3sigma_enu": [1.0, 1.0, 1.0], "nees_pos_mean": 3.0}]
    write(docs / "measurements", "accuracy.json", {"meta": META, "rows": rows})
    nav = ["index.md", "methods/index.md",
           {"Validation": ["validation/index.md", *validation.PAGES]}]
    (tmp_path / "mkdocs.yml").write_text(json.dumps({
        "site_name": "t", "docs_dir": str(docs), "site_dir": str(tmp_path / "site"),
        "strict": True, "hooks": [str(HOOK)], "nav": nav}))
    build(load_config(str(tmp_path / "mkdocs.yml")))
    site = tmp_path / "site" / "validation"
    assert "0.432" in (site / "accuracy" / "index.html").read_text()
    assert "Not measured yet" in (site / "speed" / "index.html").read_text()
    assert not (docs / "validation").exists()               # nothing written into docs/


def test_harbour_page_shows_acceptance_and_every_object(tmp_path: Path) -> None:
    rows = [{"seed": 3, "object": "B2", "role": "ship", "match": "O1", "coverage_moving": 0.812,
             "followed": None, "rmse": 10.12, "rmse_hull": 7.41, "antenna_offset_m": 5.8,
             "swaps": 0, "inside_3sigma": 0.97, "nees": 0.64, "gospa_mean": 19.6,
             "gnn_match": "S4", "gnn_coverage_moving": 0.955, "gnn_rmse": 8.73, "gnn_swaps": 43,
             "gnn_inside_3sigma": 0.88},
            {"seed": 3, "object": "M1", "role": "moored", "match": None,
             "coverage_moving": None, "followed": 0.0, "antenna_offset_m": 2.1, "swaps": 0,
             "gnn_followed": 0.87}]
    acc = {"rangeproc": {"ship": {"objects": 1, "accepted": 0, "outside": ["3 B2: coverage"]},
                         "moored": {"objects": 1, "accepted": 1, "outside": []}}}
    write(tmp_path, "harbour.json", {"meta": META, "rows": rows, "acceptance": acc})
    text = page("validation/harbour.md", tmp_path)
    for n in ("0.812", "10.12", "7.41", "0.955", "0.870", "3 B2: coverage", "0 of 1",
              "1 of 1", "Test CPU 9000"):
        assert n in text, n
