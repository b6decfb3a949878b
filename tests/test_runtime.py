"""roadbank.runtime: the process settings of the command and its workers. Freed memory stays in the
process (fewer page faults for the next log's arrays), and an explicit user setting wins."""

from __future__ import annotations

import json
import platform
import subprocess
import sys

import pytest

_CHILD = r"""
import json, resource, sys
from roadbank import runtime
kept = runtime.keep_freed_memory() if sys.argv[1] == "keep" else False
import numpy as np
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
np.ones(2**19).sum()          # numpy's own start-up faults before the count
f0 = faults()
for _ in range(200):          # a log's worth of arrays, made and freed again and again
    a = [np.ones(2**17) for _ in range(8)]   # 8 arrays of 1 MiB
    del a
print(json.dumps({"kept": kept, "faults": faults() - f0}))
"""


def _clean_env() -> dict:
    """This process's environment without glibc malloc settings (importing dask.distributed, as
    other tests do, sets ``MALLOC_TRIM_THRESHOLD_`` in it)."""
    import os
    return {k: v for k, v in os.environ.items() if k not in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_",
                                                            "GLIBC_TUNABLES")}


def _faults(mode: str, env: dict | None = None) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, mode], capture_output=True, text=True, timeout=120,
                         env=_clean_env() if env is None else env)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc's mallopt only")
def test_freed_memory_is_reused_without_new_page_faults():
    default, kept = _faults("default"), _faults("keep")
    assert kept["kept"] is True
    # 200 rounds of 8 MiB: with glibc's defaults each 1 MiB array is its own mapping, faulted in anew
    # (about 256 faults a MiB); kept, the rounds after the first reuse the same heap pages
    assert default["faults"] > 200 * 8 * 100
    assert kept["faults"] < default["faults"] / 20


def test_an_explicit_malloc_setting_of_the_user_wins():
    env = dict(_clean_env(), MALLOC_MMAP_THRESHOLD_="131072")
    assert _faults("keep", env)["kept"] is False


def test_the_command_sets_its_defaults_and_keeps_the_users():
    import os
    code = ("import os, roadbank.cli, json; print(json.dumps({k: os.environ.get(k) for k in "
            "('OPENBLAS_NUM_THREADS', 'ARROW_DEFAULT_MEMORY_POOL')}))")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "ARROW_DEFAULT_MEMORY_POOL")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert json.loads(out.stdout) == {"OPENBLAS_NUM_THREADS": "1", "ARROW_DEFAULT_MEMORY_POOL": "system"}
    env["OPENBLAS_NUM_THREADS"] = "4"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert json.loads(out.stdout)["OPENBLAS_NUM_THREADS"] == "4"
