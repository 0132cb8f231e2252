"""The ``neweul`` command: a thin layer over the Python API.

Each sub-command lives in its own module under :mod:`neweul_py.commands` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` (called with the parsed
arguments, returning an exit code). The CLI catches :class:`~neweul_py.errors.NeweulError` and
:class:`OSError` (a file that cannot be written: disk full, permissions) and prints one line; any
other exception is a bug and keeps its traceback.

Exit codes (docs/cli.md), the same for every command: 0 success; 1 an error of the input or the
model; 2 a malformed command line (argparse); 3 a check that ran and failed
(:data:`neweul_py.commands.EXIT_CHECK_FAILED`: ``compare`` beyond its tolerances, ``sweep`` with
failed cases); 130 an interrupt.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import re
import sys
import warnings
from collections.abc import Sequence

from .errors import NeweulError

#: Modules of :mod:`neweul_py.commands` that provide sub-commands, in help order.
COMMAND_MODULES: tuple[str, ...] = (
    "generate",
    "simulate",
    "equilibrium",
    "linearize",
    "modes",
    "frf",
    "sensitivity",
    "identify",
    "reduce",
    "compare_frf",
    "frf_body",
    "body_info",
    "interpolate",
    "fem",
    "middle_ear",
    "sweep", "compare",
    "export",
)


#: Words that are values, not options: ``-4000``, ``-4000:4000:9``, ``-4000,0,4000``, ``-1e-3``.
NEGATIVE_VALUE = re.compile(r"-\d[\d.:,eE+-]*")
#: ``argument --f: --f START: …`` → ``argument --f: START: …``.
_REPEATED_OPTION = re.compile(r"^(argument (\S+?)(?:/\S+)?: )\2 ?:? ?")
#: An option word without an attached value: ``--values``, ``-p``.
_OPTION_WORD = re.compile(r"--?[A-Za-z][\w-]*")


def attach_negative_values(args: Sequence[str]) -> list[str]:
    """``["--values", "-4000,0"]`` → ``["--values=-4000,0"]`` (``-p -1`` → ``-p-1``): an option
    followed by a negative number, range or list gets it attached, so that argparse reads it as
    the option's value rather than as an unknown option (argparse alone only accepts plain
    ``-4000``-like words)."""
    out: list[str] = []
    i = 0
    args = list(args)
    while i < len(args):
        word = args[i]
        if (word != "--" and i + 1 < len(args) and _OPTION_WORD.fullmatch(word)
                and NEGATIVE_VALUE.fullmatch(args[i + 1])):
            out.append(f"{word}={args[i + 1]}" if word.startswith("--") else word + args[i + 1])
            i += 2
            continue
        if word == "--":
            out.extend(args[i:])
            break
        out.append(word)
        i += 1
    return out


class NeweulArgumentParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` that accepts negative numbers, ranges and lists as
    option values (:func:`attach_negative_values`), through the public ``parse_known_args``."""

    def error(self, message: str):  # type: ignore[override]
        """argparse's usage and error line, without repeating the option the checks of
        :mod:`neweul_py.commands` name themselves (``argument --f: --f START: …``)."""
        super().error(_REPEATED_OPTION.sub(r"\1", message))

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        if args is None:
            args = sys.argv[1:]
        return super().parse_known_args(attach_negative_values(args), namespace)


class _VersionAction(argparse.Action):
    """``--version``: print ``neweul <version of the installed package>`` and exit (the
    metadata is read only then, so that other commands start without it)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=default,
                         help=help or "show the version (from the package metadata) and exit")

    def __call__(self, parser, namespace, values, option_string=None):  # type: ignore[override]
        from .version import installed_version

        print(f"neweul {installed_version()}")
        parser.exit()


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every available sub-command registered, or only ``command``
    when that names one (``"generate"``, ``"compare-frf"`` …).

    Registering imports no analysis, elastic or symbolic code (see :mod:`neweul_py.commands`),
    so that ``neweul --help`` starts fast. A run of one sub-command needs its own parser only:
    its usage, help and errors are the same (the sub-commands are shown as ``COMMAND``), and
    the other 13 modules and parsers are not built (≈ 12 ms of every ``neweul`` process).
    """
    parser = NeweulArgumentParser(
        prog="neweul",
        description="Equations of motion of elastic multibody systems: generate, simulate, "
        "analyse, reduce.",
    )
    parser.add_argument("--version", action=_VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    module = None if command is None else command.replace("-", "_")
    for name in (module,) if module in COMMAND_MODULES else COMMAND_MODULES:
        # a missing command module is a broken installation: let its ImportError show
        importlib.import_module(f"neweul_py.commands.{name}").register(sub)
    return parser


#: Thresholds of the cyclic garbage collector for a CLI process (CPython's default is
#: ``(700, 10, 10)``). Importing sympy and deriving create millions of short-lived, acyclic
#: objects that reference counting frees, and a few hundred thousand that live to the end; a
#: generation-0 collection traverses every young object still alive. Collector time of a cold
#: ``neweul generate`` of the chain N = 10 (in-process ``gc.callbacks``, 2026-12-02): default
#: thresholds ≈ 7 % of the process; 20 000: 28 ms (18 collections); 100 000: 21–35 ms (one
#: collection of ~10⁵ objects); 200 000: 0.8 ms (none during the derivation). Cyclic garbage is
#: still collected, after 200 000 net allocations instead of 700 (tens of MB at most).
GC_THRESHOLDS = (200_000, 10, 10)


#: Thread counts of the BLAS libraries for a CLI process, unless the environment sets them:
#: the commands' linear algebra is sparse factorizations (SuperLU calls BLAS on small
#: supernodes), ARPACK and small dense matrices, where threads only wait for each other. On a
#: shared 2-core machine OpenBLAS's spinning threads made ``neweul compare-frf`` of the
#: refine-1 middle ear (200 frequencies) take more than 400 s instead of 9 s CPU.
BLAS_THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``neweul`` console script (``argv`` None: ``sys.argv``, and the
    process ends when this returns, see :func:`_before_exit`). BLAS runs single-threaded
    (:data:`BLAS_THREADS`) unless the environment says otherwise; it takes effect when NumPy
    is not imported yet, as in the console script."""
    for name, value in BLAS_THREADS.items():
        os.environ.setdefault(name, value)
    words = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(words[0] if words else None)
    args = parser.parse_args(words)

    def one_line(message, category, filename, lineno, file=None, line=None):
        print(f"neweul {args.command}: warning: {message}", file=sys.stderr)

    previous, warnings.showwarning = warnings.showwarning, one_line
    gc_before = gc.get_threshold()      # restored: in-process callers keep their own
    gc.set_threshold(*GC_THRESHOLDS)
    try:
        return _run(args)
    finally:
        warnings.showwarning = previous
        if argv is None:
            _before_exit()
        gc.set_threshold(*gc_before)


def _before_exit() -> None:
    """Exempt every object of the finished command from the cyclic garbage collector
    (:func:`gc.freeze`): the console script's process ends next, and the interpreter's
    collection at shutdown would traverse each of the ~10⁶ objects of sympy and of the
    derivation once more — ≈ 0.1 s CPU of a cold ``neweul generate`` (chain N = 10: 0.67 →
    0.54 s), for garbage the exit frees anyway. Objects are still freed by reference
    counting; only cycles left by the command stay until the process exits."""
    gc.freeze()


#: The signal number of a write to a closed pipe (POSIX); a command ended by it exits with
#: 128 + this, as the shell reports a process killed by the signal.
SIGPIPE = 13


def _quiet_stdout() -> None:
    """Point stdout at the null device, so that the interpreter's flush at exit finds no
    closed pipe (Python docs, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):      # no file descriptor (an in-process caller's stream)
        pass


def _run(args: argparse.Namespace) -> int:
    """Run the chosen sub-command; every :class:`NeweulError` becomes one line on stderr."""
    try:
        return int(args.func(args) or 0)
    except NeweulError as exc:
        print(f"neweul {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:     # the reader of stdout left (`neweul … | head`): no message
        _quiet_stdout()
        return 128 + SIGPIPE
    except OSError as exc:
        name = exc.filename2 or exc.filename  # os.replace: the target is filename2
        where = f"{name}: " if name else ""
        print(f"neweul {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
    except ArithmeticError as exc:  # raised by a generated module: exp(1000), 1/0 …
        hint = (": a spring_damper whose points coincide has no direction (see "
                "docs/description-format.md, zero-length springs)"
                if isinstance(exc, ZeroDivisionError) else "")
        print(f"neweul {args.command}: error: the model cannot be evaluated "
              f"({type(exc).__name__}: {exc}){hint}", file=sys.stderr)
        return 1
    except (MemoryError, RecursionError) as exc:  # never a traceback for too big an input
        what = "memory" if isinstance(exc, MemoryError) else "nesting depth"
        print(f"neweul {args.command}: error: the input needs more {what} than this machine "
              "allows (see docs/limits.md)", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"neweul {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
