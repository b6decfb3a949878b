"""Streaming bank-angle estimation, one sample at a time, as an ECU task or a ROS node would run it.

The estimator is built once (its gain schedule is designed up front); then each
incoming sample (t, vx, ay, r, delta_f) -- SI, ISO 8855 -- goes through
``step()``, which returns the estimate for that instant. No look-ahead, no
buffering: the numbers are identical to ``run()`` on the whole log.

    python examples/stream.py [LOG] [--estimator pif-modified]

LOG is anything ``roadbank.io.load_log`` reads (default: the comma2k19 example
segment next to the repository). In a ROS node, ``on_sample`` would be the
subscriber callback of a synchronised (vx, ay, r, steering) message and the
result would be published instead of collected.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from roadbank import estimators
from roadbank.io import load_log


class BankNode:
    """Minimal real-time wrapper: one estimator, fed sample by sample."""

    def __init__(self, name: str = "pif-modified", params=None):
        self.estimator = estimators.make(name, params=params)
        self.estimator.reset()

    def on_sample(self, t: float, vx: float, ay: float, r: float, delta_f: float):
        """Handle one sample; returns (theta, phi_b, valid) in rad."""
        out = self.estimator.step(t, vx, ay, r, delta_f)
        return out.theta, out.phi_b, out.valid


def stream(signals, name: str = "pif-modified", params=None) -> dict[str, np.ndarray]:
    """Feed ``signals`` one sample at a time through a :class:`BankNode`; collect the outputs."""
    node = BankNode(name, params)
    n = len(signals)
    theta, phi_b, valid = np.empty(n), np.empty(n), np.empty(n, dtype=bool)
    for i in range(n):
        theta[i], phi_b[i], valid[i] = node.on_sample(
            float(signals.t[i]), float(signals.vx[i]), float(signals.ay[i]),
            float(signals.r[i]), float(signals.delta_f[i]))
    return {"theta": theta, "phi_b": phi_b, "valid": valid}


def main(argv=None) -> None:
    default = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "comma2k19-example"
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log", nargs="?", default=str(default))
    ap.add_argument("--estimator", default="pif-modified", choices=estimators.NAMES)
    a = ap.parse_args(argv)
    log = load_log(a.log)
    out = stream(log.signals, a.estimator)
    batch = estimators.make(a.estimator).run(log.signals)
    diff = np.max(np.abs(out["theta"] - batch.theta))
    print(f"{len(log.signals)} samples streamed through {a.estimator}; "
          f"final theta = {math.degrees(out['theta'][-1]):.3f} deg, "
          f"max |stream - batch| = {diff:.3g} rad")


if __name__ == "__main__":
    main()
