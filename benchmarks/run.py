"""Run the benchmark suite from a checkout: ``python benchmarks/run.py [-o docs/benchmarks.md] [--quick] [--json]``.

Same as ``roadbank bench``; the suite itself lives in :mod:`roadbank.bench`
(the command only parses options and prints).
"""

import sys

from roadbank.cli.bench import bench

if __name__ == "__main__":
    sys.argv[0] = "roadbank bench"
    bench(prog_name="roadbank bench")
