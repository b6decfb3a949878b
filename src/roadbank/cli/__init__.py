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
import os  # noqa: E402

import click  # noqa: E402

#: set (to anything but "" or "0") to let an unexpected error out with its traceback instead of the one-line message
TRACEBACK_ENV = "ROADBANK_TRACEBACK"
#: the exit code of a command stopped by Ctrl-C (128 + SIGINT, as shells report it); 0 is success, 1 a failed log or
#: a one-line error, 2 a usage error
EXIT_INTERRUPTED = 130

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

    def invoke(self, ctx):
        """Run the sub-command; an error that no reader or command turned into its own message ends in one line
        (exit code 1), never a traceback: a file the system refuses (``OSError``: named with the system's reason),
        memory that ran out, or a bug (its type and text, with how to see the traceback: :data:`TRACEBACK_ENV`).
        Ctrl-C ends with :data:`EXIT_INTERRUPTED`."""
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except KeyboardInterrupt:           # Ctrl-C: the shell's code for it, told apart from a failed log
            click.echo("\ninterrupted (Ctrl-C)", err=True)
            ctx.exit(EXIT_INTERRUPTED)
        except Exception as exc:
            if os.environ.get(TRACEBACK_ENV, "") not in ("", "0"):
                raise
            click.echo(f"error: {unexpected(exc)}", err=True)
            ctx.exit(1)

    def get_command(self, ctx, name):
        spec = self._spec(name)
        if spec is None:
            return None
        module, attr = spec.split(":")
        return getattr(importlib.import_module(f"roadbank.cli.{module}"), attr)


def unexpected(exc: BaseException) -> str:
    """The one-line message for an error that reached the command line unhandled (:meth:`_LazyGroup.invoke`)."""
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return f"{where}{exc.strerror or exc}"
    if isinstance(exc, MemoryError):
        return ("out of memory (a log too large for this machine, or one whose time stamps span far more than its "
                "samples; --chunk-rows reads a long log in pieces)")
    return (f"unexpected {type(exc).__name__}: {exc} -- a bug in roadbank; please report it with the command "
            f"(set {TRACEBACK_ENV}=1 to see where it happened)")


@click.group(cls=_LazyGroup)
@click.version_option(package_name="roadbank")
def main():
    """roadbank: road bank angle estimation (Kim, Lee, Choi 2012) and its evaluation."""


if __name__ == "__main__":  # pragma: no cover
    main()
