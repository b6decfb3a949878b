"""The ``roadbank`` command line.

Each sub-command lives in its own module of this package and is imported only
when it is invoked, so ``roadbank --help`` is fast and a command never pays the
numba compilation of estimators it does not use.
"""

from __future__ import annotations

# the process's settings (one BLAS thread, Arrow's allocator, freed memory kept for the next
# log: roadbank.runtime), before numpy is imported; an explicit user setting wins
from .. import runtime

runtime.configure()

import importlib  # noqa: E402
import importlib.util  # noqa: E402

import click  # noqa: E402

#: sub-command name -> "module:function" inside roadbank.cli
COMMANDS = {
    "simulate": "simulate:simulate",
    "estimate": "estimate:estimate",
    "validate": "validate:validate",
    "reproduce": "reproduce:reproduce",
    "bench": "bench:bench",
    "campaign": "campaign:campaign",
    "robustness": "robustness:robustness",
    "map": "map:map_command",
    "export": "export:export",
    "identify": "identify:identify",
    "tune": "tune:tune",
    "channels": "channels:channels",
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(name for name in COMMANDS if self._spec(name) is not None)

    @staticmethod
    def _spec(name):
        spec = COMMANDS.get(name)
        if spec is None:
            return None
        module = spec.split(":")[0]
        return spec if importlib.util.find_spec(f"roadbank.cli.{module}") is not None else None

    def get_command(self, ctx, name):
        spec = self._spec(name)
        if spec is None:
            return None
        module, attr = spec.split(":")
        return getattr(importlib.import_module(f"roadbank.cli.{module}"), attr)


@click.group(cls=_LazyGroup)
@click.version_option(package_name="roadbank")
def main():
    """roadbank: road bank angle estimation (Kim, Lee, Choi 2012) and its evaluation."""


if __name__ == "__main__":  # pragma: no cover
    main()
