"""Shared arguments of the analysis sub-commands (simulate, equilibrium, linearize, modes, frf).

FILE is a YAML description (generated into the cache first, or reused when unchanged) or an
already generated module ``.py`` (then no symbolic layer, no sympy, is imported). Result and plot
file names are checked before anything is computed (:func:`check_files`).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import NeweulError
from . import BACKENDS, FORMS
from . import assignment as _assignment

#: Parsing ``NAME=NUMBER`` (finite, in range): :func:`neweul_py.commands.assignment`.
assignment = _assignment


def add_output_argument(parser: argparse.ArgumentParser, metavar: str, text: str,
                        **kwargs: Any) -> None:
    """``-o/--output FILE``, the results file of every command (``--out`` is kept as the old
    spelling)."""
    parser.add_argument("-o", "--output", "--out", dest="output", metavar=metavar, help=text,
                        **kwargs)


def add_signal_arguments(parser: argparse.ArgumentParser, required: bool) -> None:
    """``--input U`` and ``--response Y`` (repeatable) of frf and compare-frf; the old
    spelling ``--output Y`` of the response still works (a name has no dot, a file has a
    suffix: :func:`split_output`)."""
    parser.add_argument("--input", action="append", required=required, metavar="U",
                        help="input name (repeatable)")
    parser.add_argument("--response", action="append", metavar="Y",
                        help="response (output) name (repeatable)")
    parser.add_argument("-o", "--output", "--out", dest="output", action="append", default=[],
                        metavar="FILE", help="results file (.csv or .npz); '--output NAME' "
                        "without a suffix is the old spelling of --response NAME")


def split_output(args: argparse.Namespace) -> None:
    """Sort ``-o/--output`` values of frf/compare-frf into the results file (``args.output``,
    one at most) and response names (appended to ``args.response``): names are identifiers
    (no dot), files need a suffix."""
    files = [v for v in args.output if "." in v or "/" in v]
    names = [v for v in args.output if v not in files]
    if len(files) > 1:
        raise NeweulError(f"-o/--output: one results file, got {', '.join(files)}")
    if names:
        args.response = [*(args.response or []), *names]
    args.output = files[0] if files else None


def add_model_arguments(parser: argparse.ArgumentParser, operating_point: bool = True) -> None:
    """FILE, --form, -p NAME=VALUE, -u NAME=VALUE, and (optionally) --at / --independent."""
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--backend", choices=BACKENDS, default="numpy",
                        help="module of a description: NumPy or compiled C (cffi)")
    add_parameter_argument(parser)
    parser.add_argument("-u", "--set-input", type=assignment, action="append", default=[],
                        metavar="NAME=VALUE",
                        help="hold an input at a value (repeatable; default: excitation at t=0)")
    parser.add_argument("--start", type=assignment, action="append", default=[],
                        metavar="COORD=VALUE",
                        help="start the equilibrium search here instead of the initial state "
                        "(repeatable)")
    parser.add_argument("--fix", action="append", default=[], metavar="COORD",
                        help="hold a coordinate at its initial value in the equilibrium search "
                        "(repeatable)")
    if operating_point:
        parser.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                            help="operating point: static equilibrium (default) or the initial "
                            "state of the model")
        add_independent_argument(parser, "constrained models: the minimal coordinates "
                                 "(default: the first coordinates the constraints leave free)")


def add_parameter_argument(parser: argparse.ArgumentParser) -> None:
    """``-p/--param NAME=VALUE`` (repeatable; a finite number in range)."""
    parser.add_argument("-p", "--param", type=assignment, action="append", default=[],
                        metavar="NAME=VALUE", help="override a parameter (repeatable)")


def add_independent_argument(parser: argparse.ArgumentParser, text: str) -> None:
    """``--independent NAME [NAME ...]`` (also repeatable), collected into one list."""
    parser.add_argument("--independent", nargs="+", action="extend", default=None,
                        metavar="NAME", help=text)


def check_files(
    output: str | None = None,
    suffixes: tuple[str, ...] = (),
    what: str = "results",
    plot: str | None = None,
) -> None:
    """Check ``-o`` (its suffix one of ``suffixes``) and ``--plot`` (matplotlib installed, a
    format it writes), and that neither lies below a file, before any computation, so that a
    typo fails at once (missing directories are created when the file is written)."""
    if output:
        from ..analysis.results import check_output_path

        check_output_path(output, suffixes, what)
        check_parents(output)
    if plot:
        from ..analysis.plot import check_plot_path

        check_plot_path(plot)
        check_parents(plot)


def check_parents(path: str | os.PathLike[str]) -> None:
    """One error when ``path`` is a directory, or a directory on the way to it is a file (the
    write would fail after the work)."""
    if Path(path).is_dir():
        raise NeweulError(f"{path}: a directory, not a file")
    for parent in Path(path).parents:
        if parent.exists():
            if not parent.is_dir():
                raise NeweulError(f"{path}: {parent} is a file, not a directory")
            return


def refuse_overwrite(output: str | None, inputs: Mapping[str, str | Sequence[str] | None],
                     option: str = "-o/--output") -> None:
    """Refuse an output file that is one of the command's input files, before any work.

    Parameters
    ----------
    output
        The file the command will write (``None``: nothing to check).
    inputs
        What names each input → its file or files (``None`` entries are skipped), e.g.
        ``{"BODY": args.bodies, "--slope-models": args.slope_models}``.
    option
        The output option, as the error names it.

    Raises
    ------
    NeweulError
        One line naming ``option``, the input and the file: the same path once resolved
        (links, ``..``) or the same file on disk (a hard link).
    """
    if not output:
        return
    out = Path(output)
    for name, files in inputs.items():
        for file in [files] if isinstance(files, str) else (files or ()):
            if file and same_file(out, Path(file)):
                raise NeweulError(f"{option} {output} is the input {name} {file}: writing it "
                                  "would overwrite that input (write to another file)")


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file: equal resolved paths, or (both existing) the
    same file on disk."""
    if a.resolve() == b.resolve():
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def load_model(args: argparse.Namespace) -> Any:
    """The generated module of ``args.file``, with the ``-p``/``-u`` overrides checked against
    it (:func:`check_overrides`)."""
    if args.file.endswith(".py"):
        from ..analysis.module import load_generated
        from ..files import check_regular_file

        module = load_generated(check_regular_file(args.file, "generated module", 512 * 2**20,
                                                   NeweulError))
    else:
        from ..api import load_description_module  # symbolic layers only on a cache miss
        from ..progress import Tracker

        with Tracker(quiet=getattr(args, "quiet", False)) as track:  # bars of a derivation
            module = load_description_module(args.file, args.form,
                                             backend=getattr(args, "backend", "numpy"),
                                             progress=track,
                                             sensitivities=getattr(args, "sensitivities",
                                                                   False))
    check_overrides(module, args)
    return module


def check_overrides(module: Any, args: argparse.Namespace) -> None:
    """Refuse ``-p``/``-u`` values that make the model meaningless, as a description refuses
    them (:func:`neweul_py.analysis.admissible.check_parameters`: declared ranges, a mass
    matrix at the initial state that is not finite or not positive semidefinite, a negative
    loss factor). The numbers themselves were checked by
    :func:`neweul_py.commands.number` (finite, in range); this check needs the model.
    """
    from ..analysis.admissible import check_parameters
    from ..analysis.protocol import resolve_inputs, resolve_parameters

    # simulate's -u takes expressions of t (commands/_signals.py checks those); numbers here
    numeric = [(k, v) for k, v in getattr(args, "set_input", []) if isinstance(v, float)]
    given = [*getattr(args, "param", []), *numeric]
    if not given:
        return
    p = resolve_parameters(module, dict(getattr(args, "param", [])) or None)
    resolve_inputs(module, 0.0, p, dict(numeric) or None)  # names
    check_parameters(module, p, ", ".join(f"{k} = {v:g}" for k, v in given))


def parameters(args: argparse.Namespace) -> dict[str, float] | None:
    """``-p`` overrides as a mapping (None without any)."""
    return dict(args.param) or None


def inputs(args: argparse.Namespace) -> dict[str, float] | None:
    """``-u`` overrides as a mapping (None without any)."""
    return dict(args.set_input) or None


def start(args: argparse.Namespace) -> dict[str, float] | None:
    """``--start`` coordinates as a mapping (None without any)."""
    return dict(args.start) or None


def linearize_kwargs(module: Any, args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`~neweul_py.analysis.linearize.linearize` for ``--at``."""
    import numpy as np

    from ..analysis.dae import consistent_initial_state
    from ..analysis.equilibrium import equilibrium

    p, u = parameters(args), inputs(args)
    kw: dict[str, Any] = {"independent": args.independent}
    if args.at == "equilibrium":
        eq = equilibrium(module, p=p, u=u, y0=start(args), fixed=args.fix)
        kw.update(y0=eq, p=eq.p, u0=eq.u)
        return kw
    n = len(module.COORDINATES)
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    y0, yd0 = x0[:n], x0[n : 2 * n]
    if module.CONSTRAINTS:
        if np.any(yd0):
            raise NeweulError(
                "--at initial: the initial state moves (ẏ0 ≠ 0); constrained models are "
                "linearized about rest points — use --at equilibrium"
            )
        y0, yd0 = consistent_initial_state(module, y0, yd0, p, independent=args.independent)
    kw.update(y0=y0, yd0=yd0, p=p, u0=u)
    return kw
