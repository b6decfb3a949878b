"""A newcomer's first commands: the library's submodules after ``import roadbank``, and ``roadbank
estimate``'s paths (a new output folder, a folder of KITTI drives, a glob with a README, -e all)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io.writers import write_table

SRC = Path(__file__).resolve().parents[1] / "src"
KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts"


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                          env={"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "1"})


def test_submodules_after_a_bare_import():
    res = _run("import sys, roadbank\n"
               "assert 'roadbank.vehicle' not in sys.modules and 'numpy' not in sys.modules\n"
               "car = roadbank.vehicle.load_vehicle('sedan')\n"
               "print(type(car).__name__, roadbank.io.load_log.__name__, roadbank.estimators.NAMES[0])\n"
               "print('vehicle' in dir(roadbank))")
    assert res.returncode == 0, res.stderr
    from roadbank.estimators import NAMES
    assert res.stdout.split() == ["Vehicle", "load_log", NAMES[0], "True"]
    bad = _run("import roadbank; roadbank.nonesuch")
    assert bad.returncode != 0 and "has no attribute 'nonesuch'" in bad.stderr


def _log(path: Path, n=600, bank=0.05):
    t = np.arange(n) * 0.01
    z = np.zeros(n)
    write_table(path, {"t": t, "vx": z + 20.0, "ay": z + 9.81 * np.sin(bank), "r": z, "delta_f": z})
    return path


def test_one_log_into_a_new_folder(tmp_path):
    log = _log(tmp_path / "one.csv")
    out = tmp_path / "newdir"
    res = CliRunner().invoke(main, ["estimate", str(log), "-e", "kinematic", "-o", str(out) + "/"])
    assert res.exit_code == 0, res.output
    assert (out / "one.bank.parquet").is_file() and (out / "summary.csv").is_file()


def test_glob_with_a_readme_skips_it(tmp_path):
    d = tmp_path / "logs"
    d.mkdir()
    _log(d / "a.csv")
    _log(d / "b.csv", bank=0.02)
    (d / "README.md").write_text("# my drives\n")
    args = sorted(str(p) for p in d.iterdir())            # what the shell makes of logs/*
    res = CliRunner().invoke(main, ["estimate", *args, "-e", "kinematic", "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert f"skipped {d / 'README.md'} (not a log of a known format: suffix '.md')" in res.output
    res = CliRunner().invoke(main, ["estimate", *args, "--format", "csv", "-e", "kinematic",
                                    "-o", str(tmp_path / "out2")])
    assert res.exit_code == 0, res.output
    assert f"skipped {d / 'README.md'} (not a csv log)" in res.output
    assert "2 log(s) written, 0 failed" in res.output


@pytest.mark.slow
def test_all_estimators_summarised(tmp_path):
    from roadbank import estimators
    log = _log(tmp_path / "one.csv", n=800)
    res = CliRunner().invoke(main, ["estimate", str(log), "-e", "all", "-o", str(tmp_path / "o.parquet"), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    per = doc["logs"][0]["estimators"]
    assert list(per) == list(estimators.NAMES)
    # each estimator's numbers are those of its columns in the table written
    import pyarrow.parquet as pq
    tab = pq.read_table(tmp_path / "o.parquet").to_pydict()
    for name, st in per.items():
        valid = np.asarray(tab[f"{name}.valid"], dtype=bool)
        phi = np.degrees(np.asarray(tab[f"{name}.phi_b"])[valid])
        assert st["valid_share"] == pytest.approx(valid.mean(), abs=1e-12), name
        if valid.any():
            assert st["bank_mean_deg"] == pytest.approx(phi.mean(), abs=1e-9), name
            assert st["bank_max_deg"] == pytest.approx(phi.max(), abs=1e-9), name
    # kinematic on a straight banked road: theta is the bank itself (ay = g sin(bank))
    np.testing.assert_allclose(tab["kinematic.theta"], 0.05, atol=1e-9)
    res = CliRunner().invoke(main, ["estimate", str(log), "-e", "all", "-o", str(tmp_path / "o.parquet")])
    assert res.exit_code == 0, res.output
    rows = [ln.split()[0] for ln in res.stdout.splitlines()[2:] if ln.strip()]
    named = [ln.split()[1] if i == 0 else ln.split()[0] for i, ln in enumerate(res.stdout.splitlines()[2:])]
    assert rows[0] == "one.csv" and named == list(estimators.NAMES), res.stdout


@pytest.mark.skipif(not KITTI.is_dir(), reason="shared KITTI drives not present")
def test_folder_of_kitti_drives(tmp_path):
    from roadbank.validation.kitti import expand_drives
    drives = expand_drives([KITTI])
    assert len(drives) >= 2                         # what `validate kitti` takes from this folder
    res = CliRunner().invoke(main, ["estimate", str(KITTI) + "/", "-e", "kinematic", "-o", str(tmp_path / "k")])
    assert res.exit_code == 0, res.output
    assert f"{len(drives)} log(s) written, 0 failed" in res.output
    for d in drives:
        assert (tmp_path / "k" / f"{d.name}.bank.parquet").is_file()


def test_a_spreadsheet_is_skipped_with_what_to_do(tmp_path):
    """An Excel or LibreOffice file among the logs: skipped, saying to save it as CSV (which roadbank reads with
    ';', decimal commas and a units row); the CSV beside it is estimated."""
    d = tmp_path / "logs"
    d.mkdir()
    _log(d / "a.csv")
    (d / "drive.xlsx").write_bytes(b"PK\x03\x04 not really a workbook")
    res = CliRunner().invoke(main, ["estimate", str(d / "a.csv"), str(d / "drive.xlsx"), "-e", "kinematic",
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert f"skipped {d / 'drive.xlsx'} (not a log of a known format: suffix '.xlsx' (a spreadsheet: save it as " \
           "CSV;" in res.output, res.output
    assert "1 log(s) written, 0 failed" in res.output


@pytest.mark.parametrize("args, words", [(["--chunk-rows", "1"], "--chunk-rows"),
                                         (["--chunk-rows", "0"], "--chunk-rows"),
                                         (["-e", ""], "no estimator named"), (["-e", " , "], "no estimator named")])
def test_an_option_without_sense_is_a_usage_error_before_any_log_is_read(tmp_path, args, words):
    log = _log(tmp_path / "one.csv")
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(tmp_path / "o.csv"), *args])
    assert res.exit_code == 2 and words in res.output, res.output
    assert not (tmp_path / "o.csv").exists()
