"""``nlid-lab`` command line: sub-commands live in `nlid_lab.commands`, one module each.

Exit codes: 0 success, 2 bad input (one line on stderr, no traceback), 1 any other failure.
Set ``NLID_DEBUG=1`` to see tracebacks.

BLAS runs on one thread for a command (`blas_threads`) unless the environment sets its
threads (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ...): the estimators work on small
matrices, where OpenBLAS's threads cost more than they save (docs/simulated-plant.md).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import pkgutil
import sys
import warnings
from collections.abc import Iterator
from typing import Sequence

from analysis.errors import InputError

from . import __version__, commands


#: Commands that run no numba kernel (no "compiling" notice for them).
NO_KERNELS = frozenset({"import", "import-modes", "repair", "warmup"})
#: Variables that set the BLAS threads (OpenBLAS reads the first three; MKL, BLIS their own):
#: when one is set, the CLI leaves the threads to it.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS",
                         "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``nlid-lab`` parser with every sub-command in `nlid_lab.commands`."""
    parser = _Parser(prog="nlid-lab", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"nlid-lab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def _bad_input_types() -> tuple[type[BaseException], ...]:
    return (InputError, FileNotFoundError, IsADirectoryError, PermissionError)


@contextlib.contextmanager
def blas_threads() -> Iterator[None]:
    """BLAS on one thread inside the block unless a `BLAS_THREAD_VARIABLES` entry is set.

    ``OPENBLAS_NUM_THREADS=1`` holds for the BLAS libraries loaded inside the block (a
    command imports numpy and scipy when it needs them) and for the processes it starts;
    those already loaded (a caller in the same process) are limited with threadpoolctl.
    Both are undone at the end; a library first loaded inside keeps its one thread."""
    if any(name in os.environ for name in BLAS_THREAD_VARIABLES):
        yield
        return
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    limits = None
    if "numpy" in sys.modules:
        from threadpoolctl import threadpool_limits   # only then: no cost at start-up
        limits = threadpool_limits(limits=1, user_api="blas")
    try:
        yield
    finally:
        os.environ.pop("OPENBLAS_NUM_THREADS", None)
        if limits is not None:
            limits.restore_original_limits()


@contextlib.contextmanager
def _held_runtime_warnings(hold: bool) -> Iterator[list[str]]:
    """Collect numpy's floating-point RuntimeWarnings (one line each) instead of printing
    them: a bad input that ends in a one-line error must not bring a screen of them."""
    held: list[str] = []
    with warnings.catch_warnings():
        show = warnings.showwarning

        def keep(message, category, filename, lineno, file=None, line=None):  # noqa: ANN001
            if hold and issubclass(category, RuntimeWarning):
                held.append(f"warning: {category.__name__}: {message}")
            else:
                show(message, category, filename, lineno, file, line)
        warnings.showwarning = keep
        yield held


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code (0
    success, 2 bad input, 1 other failure, 130 interrupted). BLAS on one thread unless the
    environment says otherwise (`blas_threads`, set before numpy loads)."""
    with blas_threads():
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    debug = os.environ.get("NLID_DEBUG") == "1"
    held: list[str] = []
    try:
        if args.command not in NO_KERNELS:
            _say_if_compiling()
        with _held_runtime_warnings(not debug) as held:
            result = args.func(args)
    except _bad_input_types() as exc:
        if debug:
            raise
        print(f"nlid-lab: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("nlid-lab: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the CLI's last line of defence
        if debug:
            raise
        _print_unique(held)
        print(f"nlid-lab: failed: {type(exc).__name__}: {_one_line(exc)} "
              "(set NLID_DEBUG=1 for a traceback)", file=sys.stderr)
        return 1
    _print_unique(held)
    return int(result or 0)


def _say_if_compiling() -> None:
    from .warmup import kernels_cached   # numba: only for commands that run kernels
    if not kernels_cached():
        print("nlid-lab: compiling numeric kernels (first run only, up to a minute; "
              "`nlid-lab warmup` does it ahead)...", file=sys.stderr, flush=True)


def _print_unique(lines: list[str]) -> None:
    for line in dict.fromkeys(lines):
        print(line, file=sys.stderr)


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.strerror or exc}: {exc.filename}"
    return " ".join(str(exc).split())


if __name__ == "__main__":
    sys.exit(main())
