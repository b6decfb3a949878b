"""Odd option values on every command are usage errors before any work, never tracebacks: a negative or
too large --seed, a --scheduler that is not an address (and one that cannot be reached), an output whose
folder is a file, tune's -o that is not a .toml file."""

from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.cli.options import output_path_problem
from roadbank.cli.parallel import address_problem


def _run(args, where, monkeypatch):
    monkeypatch.chdir(where)
    return CliRunner().invoke(main, args)


def _usage_error(res, *words):
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and not isinstance(res.exception, (ValueError, TypeError, OSError))
    for w in words:
        assert w in res.output, (w, res.output)


# ---------------------------------------------------------------- --seed
SEEDED = {"simulate": ["simulate", "const-bank", "-o", "s.csv"], "reproduce": ["reproduce", "-o", "r"],
          "validate sim": ["validate", "sim", "-o", "v.md"], "tune": ["tune", "-o", "t.toml"],
          "campaign": ["campaign", "--runs", "1", "-o", "c"]}


@pytest.mark.parametrize("seed", ["-1", str(2**32)])
@pytest.mark.parametrize("command", list(SEEDED))
def test_a_seed_numpy_cannot_take_is_a_usage_error(tmp_path, monkeypatch, command, seed):
    res = _run(SEEDED[command] + ["--seed", seed], tmp_path, monkeypatch)
    _usage_error(res, "--seed", "0<=x<=4294967295")
    assert list(tmp_path.iterdir()) == []                    # nothing written, no folder made


def test_the_largest_seed_simulates(tmp_path, monkeypatch):
    res = _run(["simulate", "const-bank", "--seed", str(2**32 - 1), "-o", "s.csv"], tmp_path, monkeypatch)
    assert res.exit_code == 0, res.output
    assert (tmp_path / "s.csv").is_file() and "seed 4294967295" in res.output


# ---------------------------------------------------------------- --scheduler
@pytest.mark.parametrize("address,why", [
    ("notanaddress", "has no port"), ("tcp://host", "has no port"), ("host:", "has no port"),
    ("tcp://host:port", "is not host:port"), ("tcp://:8786", "is not host:port"), ("tcp://h:8786/", "is not host"),
    ("http://host:8786", "unknown protocol 'http'"), ("tcp://host:0", "not in 1-65535"),
    ("host:65536", "not in 1-65535"), ("a b:8786", "is not host:port"),
])
def test_malformed_addresses(address, why):
    assert why in (address_problem(address) or "")


@pytest.mark.parametrize("address", ["tcp://10.0.0.5:8786", "localhost:8786", "TCP://h.example.com:1",
                                     "tcp://[::1]:8786", "tls://host:8786", "ws://h:80", "inproc://192.0.2.2/1/1"])
def test_well_formed_addresses(address):
    assert address_problem(address) is None


SCHEDULED = {"validate kitti": ["validate", "kitti", "."], "validate comma2k19": ["validate", "comma2k19", "."],
             "validate all": ["validate", "all", ".", "-o", "r.md"], "tune": ["tune", "-o", "t.toml"],
             "campaign": ["campaign", "--runs", "1", "-o", "c"], "estimate": ["estimate", "a.csv", "-o", "out/"],
             "map": ["map", "a.csv", "-o", "m.parquet"]}


@pytest.mark.parametrize("command", list(SCHEDULED))
def test_a_scheduler_that_is_no_address_is_a_usage_error(tmp_path, monkeypatch, command):
    res = _run(SCHEDULED[command] + ["--scheduler", "notanaddress"], tmp_path, monkeypatch)
    _usage_error(res, "--scheduler", "'notanaddress' has no port", "tcp://host:port or host:port")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("error", [ConnectionError("cannot connect to the Dask scheduler at tcp://127.0.0.1:9: "
                                                   "refused"),
                                   TypeError("TLS expects a `ssl_context` argument")])
def test_a_scheduler_that_cannot_be_used_is_one_line(tmp_path, monkeypatch, error):
    """A well-formed address passes the check and reaches the connection, whose failure is one line
    naming the address (exit code 1)."""
    from roadbank.campaign import execute

    def unusable(scheduler, workers, connect_timeout=20.0):
        raise error
    monkeypatch.setattr(execute, "open_client", unusable)
    res = _run(["validate", "kitti", ".", "--scheduler", "tcp://127.0.0.1:9"], tmp_path, monkeypatch)
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    assert "error: cannot connect to the Dask scheduler at tcp://127.0.0.1:9: " in res.output, res.output
    assert str(error).split(": ")[-1] in res.output


@pytest.mark.parametrize("command", ["tune", "campaign", "validate kitti"])
def test_a_tls_scheduler_without_tls_settings_is_one_line_before_any_work(tmp_path, command):
    """Dask itself refuses ``tls://`` without a TLS configuration (a TypeError inside its client): every
    command says so in one line naming the address (exit code 1), and tune before drawing its training
    drives. Run as a user runs it, in its own process: a Dask client that failed to start leaves Dask's
    event loop unusable for the next one in the same process."""
    pytest.importorskip("distributed")
    res = subprocess.run([sys.executable, "-m", "roadbank.cli", *SCHEDULED[command], "--scheduler",
                          "tls://127.0.0.1:1"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    out = res.stdout + res.stderr
    assert res.returncode == 1 and "Traceback" not in out, out
    assert "cannot connect to the Dask scheduler at tls://127.0.0.1:1: " in out, out
    assert "training set" not in out


# ---------------------------------------------------------------- outputs
BLOCKED = {
    "validate sim": (["validate", "sim", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "validate kitti": (["validate", "kitti", ".", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "validate comma2k19": (["validate", "comma2k19", ".", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "validate all": (["validate", "all", ".", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "reproduce": (["reproduce", "-o", "afile/r"], "-o", "cannot create directory 'afile/r'"),
    "reproduce --docs": (["reproduce", "-o", "r", "--docs", "afile/x.md"], "--docs", "cannot write 'afile/x.md'"),
    "bench": (["bench", "--tiny", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "tune": (["tune", "-o", "afile/t.toml"], "-o", "cannot write 'afile/t.toml'"),
    "campaign": (["campaign", "--runs", "1", "-o", "afile/c"], "-o", "cannot create directory 'afile/c'"),
    "simulate": (["simulate", "const-bank", "-o", "afile/s.csv"], "-o", "cannot write 'afile/s.csv'"),
    "robustness": (["robustness", "-o", "afile/x.md"], "-o", "cannot write 'afile/x.md'"),
    "channels": (["channels", "a.csv", "-o", "afile/m.toml"], "-o", "cannot write 'afile/m.toml'"),
}


@pytest.mark.parametrize("command", list(BLOCKED))
def test_an_output_under_a_file_is_a_usage_error_before_the_work(tmp_path, monkeypatch, command):
    (tmp_path / "afile").write_text("not a folder\n")
    (tmp_path / "a.csv").write_text("t,vx\n0,1\n")
    args, option, message = BLOCKED[command]
    res = _run(args, tmp_path, monkeypatch)
    _usage_error(res, option, message, "'afile' is a file, not a directory")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "afile"]      # nothing made


@pytest.mark.parametrize("args,message", [
    (["validate", "sim", "-o", "d"], "cannot write 'd': it is a directory"),
    (["channels", "a.csv", "-o", "d"], "cannot write 'd': it is a directory"),
    (["validate", "comma2k19", ".", "-o", "x.md"], "cannot write 'x.png': it is a directory"),     # its figure
    (["robustness", "-o", "x.md"], "cannot write 'x.csv': it is a directory"),                      # its table
])
def test_an_output_that_is_a_directory_is_a_usage_error(tmp_path, monkeypatch, args, message):
    (tmp_path / "a.csv").write_text("t,vx\n0,1\n")
    for d in ("d", "x.png", "x.csv"):
        (tmp_path / d).mkdir()
    _usage_error(_run(args, tmp_path, monkeypatch), "-o", message)


def test_tune_writes_toml_only(tmp_path, monkeypatch):
    res = _run(["tune", "-o", "t.csv", "--estimators", "dfc"], tmp_path, monkeypatch)
    _usage_error(res, "-o", "'t.csv' must end in .toml (tune writes a vehicle file)")
    assert "training set" not in res.output and list(tmp_path.iterdir()) == []


def test_tune_checks_its_output_before_drawing_drives(tmp_path, monkeypatch):
    """The tuning is never started for an output it could not write (it used to fail after all the work)."""
    from roadbank.tuning import pipeline

    def no_work(*args, **kwargs):
        raise AssertionError("tune_car ran")
    monkeypatch.setattr(pipeline, "tune_car", no_work)
    (tmp_path / "blocker").write_text("")
    res = _run(["tune", "-o", "blocker/t.toml", "--budget", "1", "--estimators", "dfc"], tmp_path, monkeypatch)
    _usage_error(res, "cannot write 'blocker/t.toml': 'blocker' is a file, not a directory")


def test_outputs_that_can_be_written(tmp_path):
    """A missing folder is made by the commands, an existing directory output (campaign --resume) is kept:
    neither is refused."""
    (tmp_path / "old").mkdir()
    assert output_path_problem(tmp_path / "new" / "deeper" / "t.toml", suffixes=(".toml",)) is None
    assert output_path_problem(tmp_path / "new" / "run", directory=True) is None
    assert output_path_problem(tmp_path / "old", directory=True) is None
    assert output_path_problem(tmp_path / "T.TOML", suffixes=(".toml",)) is None
    assert output_path_problem(tmp_path / "old", directory=False) is not None


@pytest.mark.parametrize("command", [["estimate", "log.csv", "-o", "out/"], ["map", "log.csv", "-o", "m.parquet"],
                                     ["validate", "kitti", "drives"], ["validate", "comma2k19", "seg"],
                                     ["validate", "all", "data", "-o", "r.md"]])
def test_workers_and_scheduler_together_are_a_usage_error(tmp_path, monkeypatch, command):
    """--workers N with --scheduler ADDR: a usage error naming both, before any input is looked at (--workers was
    ignored in silence)."""
    for name in ("drives", "seg", "data"):
        (tmp_path / name).mkdir()
    (tmp_path / "log.csv").write_text("t,vx,ay,r\n0,20,0,0\n0.01,20,0,0\n")
    res = _run(command + ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], tmp_path, monkeypatch)
    _usage_error(res, "give --workers N", "--scheduler ADDR", "not both")
    assert not (tmp_path / "out").exists() and not (tmp_path / "m.parquet").exists()
