"""One consistent command line whose numbers are checked like a
description's, and which starts fast.

References: option values that once hung or wrote NaN rows (each must end in one clear error line,
never a hang or a traceback), the option table of docs/cli.md, the caps of docs/limits.md, and
``sys.modules`` of a fresh interpreter for the imports of ``--help``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from neweul_py.cli import attach_negative_values, build_parser, main
from neweul_py.commands import CAPS, SIMULATE_METHODS, parse_range

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIXTURES = ROOT / "tests" / "analysis" / "fixtures"
TWO = str(FIXTURES / "two_mass.py")


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse: a bad option value
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["simulate", "pendulum", "--t-end", "1", "-p", "m=nan"], "m: must be a finite number"),
        (["simulate", "pendulum", "--t-end", "1", "-p", "l=inf"], "l: must be a finite number"),
        (["simulate", "pendulum", "--t-end", "1", "-p", "m=1e308"], "out of range"),
        (["linearize", TWO, "-u", "F1=nan"], "F1: must be a finite number"),
        (["frf", TWO, "--f", "nan:10:5"], "argument --f: START: must be a finite number"),
        (["frf", TWO, "--f", "1:10:1e9"], f"exceeds the cap of {CAPS['--f']}"),
        (["frf", TWO, "--f", "10:1:5"], "STOP (1) is below START (10)"),
        (["simulate", TWO, "--t-end", "1", "--n-out", "1e9"], "exceeds the cap"),
        (["simulate", TWO, "--t-end", "nan"], "--t-end: must be a finite number"),
        (["simulate", TWO, "--t-end", "1", "--rtol", "-1"], "--rtol: must be positive"),
        (["fem", "middle-ear", "--pressures", "0:1:1e9", "-o", "d"], "exceeds the cap"),
        (["fem", "middle-ear", "--refine", "5", "-o", "d"], "--refine: 5 exceeds the cap of 3"),
        (["reduce", "m.npz", "--method", "krylov", "--points", "100", "--order", "1e6", "-o",
          "b.npz"], "--order: 1e6 exceeds the cap"),
        (["reduce", "m.npz", "--band", "0:1e300", "-o", "b.npz"],
         "argument --band: HIGH: 1e+300 is out of range"),
        (["interpolate", "a.npz", "b.npz", "--parameter", "p", "--values", "1,nan", "-o",
          "p.npz"], "--values"),
        (["sweep", TWO, "--param", "m1=1", "--workers", "100000"],
         f"--workers: 100000 exceeds the cap of {CAPS['--workers']}"),
        (["sweep", TWO, "--param", "m1=1", "--workers", "0"], "--workers: must be at least 1"),
        (["sweep", TWO, "--param", "m1=1", "--chunk-size", "0"],
         "--chunk-size: must be at least 1"),
        (["sweep", TWO, "--param", "m1=1", "--timeout", "-1"], "--timeout: must be positive"),
        (["sweep", TWO, "--param", "m1=1", "--n-modes", "0"], "--n-modes: must be at least 1"),
    ],
)
def test_bad_numbers_are_refused_by_the_parser(capsys, argv, message):
    """Each option value that once hung or wrote NaN rows is refused
    before anything is read or computed: argparse's usage line and one error line, exit 2."""
    argv = [str(EXAMPLES / "pendulum.yaml") if a == "pendulum" else a for a in argv]
    code, _, err = _run(capsys, *argv)
    assert code == 2
    assert message in err and "Traceback" not in err
    assert not list(Path.cwd().iterdir())  # nothing written


def test_negative_mass_is_refused_like_in_a_description(capsys):
    """``-p m=-1`` was accepted although a description refuses a negative mass; the check
    is the physical one (the mass matrix at the initial state is not positive semidefinite),
    so it needs neither the description nor sympy."""
    code, _, err = _run(capsys, "simulate", str(EXAMPLES / "pendulum.yaml"), "--t-end", "1",
                        "-p", "m=-1")
    assert code == 1 and err.count("\n") == 1
    assert "m = -1" in err and "negative mass" in err
    code, _, err = _run(capsys, "modes", TWO, "-p", "m2=-0.5", "--at", "initial")
    assert code == 1 and "not positive semidefinite" in err


@pytest.mark.parametrize("command", ["simulate", "equilibrium", "modes"])
def test_a_value_outside_a_parameters_range_is_refused(capsys, command):
    """``-p l=-1`` of the pendulum (a length, ``l: {value: 0.5, min: 0}``) was accepted; every
    command checks -p against the description's ranges (PARAMETER_RANGES). Reference: the
    range in examples/pendulum.yaml."""
    extra = ["--t-end", "1"] if command == "simulate" else []
    code, _, err = _run(capsys, command, str(EXAMPLES / "pendulum.yaml"), *extra, "-p", "l=-1")
    assert code == 1 and err.count("\n") == 1
    assert "l = -1 is outside its range ≥ 0" in err
    code, _, err = _run(capsys, command, str(EXAMPLES / "pendulum.yaml"), *extra, "-p", "l=0.7")
    assert code == 0, err


def test_stiff_parameters_give_an_error_not_a_hang(capsys):
    """``-p ks=1e12`` (or 1e308) made RK45 take ~10⁸ steps: the fastest eigenvalue of the
    Jacobian at the start bounds the explicit steps needed (T |λ| / 3) against --max-steps."""
    desc = str(EXAMPLES / "quarter_car.yaml")
    code, _, err = _run(capsys, "simulate", desc, "--t-end", "1", "-p", "ks=1e100")
    assert code == 1 and "stiff" in err and "--method Radau" in err
    code, _, err = _run(capsys, "simulate", desc, "--t-end", "1", "-p", "ks=2e4",
                        "--max-steps", "10")
    assert code == 1 and "--max-steps 10" in err
    code, _, _ = _run(capsys, "simulate", desc, "--t-end", "0.05", "-p", "ks=2e4")
    assert code == 0


def test_nan_parameters_in_the_python_api_are_an_error():
    """The analysis functions refuse NaN parameters with a NeweulError (was LinAlgError)."""
    from neweul_py.analysis.equilibrium import equilibrium
    from neweul_py.analysis.module import load_generated
    from neweul_py.errors import NeweulError

    module = load_generated(TWO)
    with pytest.raises(NeweulError, match="finite"):
        equilibrium(module, p={"k1": float("nan")})


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["reduce", "m.npz", "--modes", "3", "-o", "x.csv"], "reduced bodies are written as .npz"),
        (["interpolate", "a.npz", "b.npz", "--parameter", "p", "-o", "p.csv"],
         "parametric bodies are written as .npz"),
        (["compare-frf", "m.npz", "b.npz", "--input", "f", "--response", "y", "-o", "c.npz"],
         "comparisons are written as .csv"),
        (["frf", TWO, "--f", "1:2:2", "-o", "frf.txt"], "frequency responses are written as"),
    ],
)
def test_output_suffixes_are_checked_everywhere(capsys, argv, message):
    """``reduce -o x.csv`` silently wrote an npz; now every -o is checked first."""
    code, _, err = _run(capsys, *argv)
    assert code == 1 and message in err and err.count("\n") == 1


def test_output_means_the_results_file_in_every_command(capsys, tmp_path):
    """``-o/--output FILE`` everywhere; frf's response is ``--response`` (the old
    ``--output NAME``, without a suffix, still names the response; ``--out`` is an alias)."""
    assert _run(capsys, "frf", TWO, "--input", "F1", "--response", "pos2", "--f", "1:10:3",
                "--output", "a.csv")[0] == 0
    assert _run(capsys, "frf", TWO, "--input", "F1", "--output", "pos2", "--f", "1:10:3",
                "--out", "b.csv")[0] == 0
    assert Path("a.csv").read_text() == Path("b.csv").read_text()
    assert _run(capsys, "simulate", TWO, "--t-end", "0.01", "--out", "s.csv")[0] == 0
    assert Path("s.csv").is_file()
    for command in ("simulate", "equilibrium", "linearize", "modes", "frf", "reduce",
                    "interpolate", "compare-frf", "generate"):
        code, out, _ = _run(capsys, command, "--help")
        assert code == 0 and "--output" in out, command


def test_one_range_syntax():
    """START:STOP:N (both ends, N points) or a comma list, for --f, --pressures, --points."""
    assert parse_range("-4000:4000:3", "--pressures").values() == [-4000.0, 0.0, 4000.0]
    assert parse_range("10,20,40", "--f").values() == [10.0, 20.0, 40.0]
    assert parse_range("1:100:3", "--f").values(log=True) == pytest.approx([1.0, 10.0, 100.0])
    args = build_parser().parse_args(["compare-frf", "a", "b", "--input", "i", "--response",
                                      "o", "--f", "5,6"])
    assert args.grid.values() == [5.0, 6.0]
    args = build_parser().parse_args(["reduce", "m", "--method", "krylov", "--points",
                                      "0:300:4", "-o", "b.npz"])
    assert args.points.values() == [0.0, 100.0, 200.0, 300.0]


def test_negative_values_without_private_argparse_api():
    """Negative numbers, ranges and lists are attached to their option before argparse
    sees them (a public override of parse_known_args)."""
    assert attach_negative_values(["--f", "-1:2:3", "-p", "-1", "x"]) == ["--f=-1:2:3", "-p-1",
                                                                       "x"]
    assert attach_negative_values(["--", "--f", "-1"]) == ["--", "--f", "-1"]
    source = (ROOT / "neweul_py" / "cli.py").read_text()
    assert "_negative_number_matcher" not in source and "._actions" not in source


def test_version(capsys):
    from neweul_py import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"neweul {__version__}"


def test_cli_choices_agree_with_the_api():
    """The constants the parser keeps (so that it imports no analysis code) are the API's."""
    from neweul_py.analysis.simulate import METHODS
    from neweul_py.analysis.sweep_tasks import STATS, TASKS
    from neweul_py.commands import SWEEP_STATS, SWEEP_TASKS
    from neweul_py.commands import interpolate as cmd
    from neweul_py.elastic.bodies import parametric as interpolation
    from neweul_py.elastic.parametric import local_interpolation

    assert SIMULATE_METHODS == METHODS
    from neweul_py.analysis.admissible import MAX_MAGNITUDE
    from neweul_py.analysis.sweep import MAX_WORKERS
    from neweul_py.commands import MAX_MAGNITUDE as CLI_MAGNITUDE

    assert CAPS["--workers"] == MAX_WORKERS and CLI_MAGNITUDE == MAX_MAGNITUDE
    assert SWEEP_TASKS == tuple(TASKS) and SWEEP_STATS == STATS
    assert cmd.INTERPOLATIONS == interpolation.INTERPOLATIONS
    assert cmd.BASES == interpolation.BASES
    assert cmd.PRESSURE_WEIGHT == local_interpolation.PRESSURE_WEIGHT
    from neweul_py.commands import compare_frf
    from neweul_py.elastic.quality import measures as quality

    assert compare_frf.FRF_METHODS == quality.FRF_METHODS


def _modules_after(code: str) -> set[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    return set(out.stdout.split())


HEAVY = ("sympy", "matplotlib", "scipy.integrate", "neweul_py.codegen", "neweul_py.equations",
         "neweul_py.elastic")


def test_help_imports_no_heavy_module():
    """``neweul --help`` (building the whole parser) imports no sympy, matplotlib,
    scipy.integrate, analysis or elastic code."""
    loaded = _modules_after(
        "import sys\nfrom neweul_py.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "print(' '.join(sys.modules))\n")
    assert "neweul_py.commands.simulate" in loaded
    heavy = sorted(m for m in loaded if m.startswith((*HEAVY, "neweul_py.analysis")))
    assert heavy == []


def test_simulate_on_a_cached_module_imports_no_sympy(tmp_path):
    """``neweul simulate FILE.yaml`` on a cache hit loads the verified module and integrates:
    scipy.integrate yes (the command needs it; SciPy's own __init__ imports scipy.optimize and
    scipy.special with it); sympy, matplotlib and the analysis code simulate does not use
    (frequency response, linearization, modes, equilibrium, animation, sweeps, plots: PEP 562
    exports of neweul_py.analysis) no."""
    desc = str(EXAMPLES / "pendulum.yaml")
    code = (f"import os, sys\nos.environ['NEWEUL_CACHE'] = {str(tmp_path / 'c')!r}\n"
            "from neweul_py.cli import main\n"
            f"assert main(['simulate', {desc!r}, '--t-end', '0.1']) == 0\n"
            "print(' '.join(sys.modules))\n")
    _modules_after(code)  # fills the cache
    loaded = _modules_after(code)
    assert "scipy.integrate" in loaded
    assert sorted(m for m in loaded if m.startswith(("sympy", "matplotlib",
                                                     "neweul_py.codegen",
                                                     "neweul_py.equations",
                                                     "neweul_py.description"))) == []
    unused = {f"neweul_py.analysis.{m}" for m in ("frf", "linearize", "modes", "equilibrium",
                                                    "animate", "sweep", "plot", "compare")}
    assert sorted(loaded & unused) == []


def test_generate_of_a_rigid_model_imports_no_numpy(tmp_path):
    """``neweul generate`` of rigid examples (a chain, a spatial chain, inputs and springs)
    derives and prints with sympy alone: a fresh process has no NumPy, SciPy, skfem,
    matplotlib, elastic or floating-frame code in ``sys.modules`` afterwards (the cold
    ``generate`` pays for no import it does not need), with the cache off or
    missing."""
    files = [str(EXAMPLES / f"{name}.yaml")
             for name in ("pendulum", "chain3_spatial", "quarter_car", "cart_pendulum")]
    code = (f"import os, sys\nos.environ['NEWEUL_CACHE'] = {str(tmp_path / 'cache')!r}\n"
            "from neweul_py.cli import main\n"
            f"for f in {files!r}:\n"
            f"    assert main(['generate', f, '-o', {str(tmp_path)!r}, '--no-cache', '-q']) == 0\n"
            f"assert main(['generate', {files[0]!r}, '-o', {str(tmp_path / 'b')!r}, '-q']) == 0\n"
            "print(' '.join(sys.modules))\n")  # the last: a cache miss, derived and stored
    loaded = _modules_after(code)
    assert "neweul_py.codegen.writer" in loaded and "sympy" in loaded
    assert sorted(m for m in loaded if m.split(".")[0] in ("numpy", "scipy", "skfem",
                                                           "matplotlib")
                  or m.startswith(("neweul_py.ffrf", "neweul_py.elastic",
                                   "neweul_py.analysis"))) == []
    assert {p.name for p in tmp_path.glob("*.py")} == {"pendulum.py", "chain3_spatial.py",
                                                       "quarter_car.py", "cart_pendulum.py"}


def test_console_run_freezes_its_objects_and_in_process_calls_do_not(tmp_path):
    """``main()`` as the console script (``argv`` None, the process exits next) hands its
    objects to ``gc.freeze`` so that the shutdown collection skips them; ``main([...])`` from
    Python (tests, notebooks) freezes nothing and gets its own GC thresholds back."""
    desc = str(EXAMPLES / "pendulum.yaml")
    code = ("import gc, sys\nfrom neweul_py.cli import main\n"
            "gc.set_threshold(700, 10, 10)\n"
            f"assert main(['generate', {desc!r}, '-o', {str(tmp_path)!r}, '--no-cache']) == 0\n"
            "assert gc.get_freeze_count() == 0 and gc.get_threshold() == (700, 10, 10)\n"
            f"sys.argv = ['neweul', 'generate', {desc!r}, '-o', {str(tmp_path)!r}, '-q']\n"
            "assert main() == 0\n"
            "print(gc.get_freeze_count() > 0, gc.get_threshold() == (700, 10, 10))\n")
    words = _modules_after(code)  # the two printed paths and the two checks
    assert "True" in words and "False" not in words


@pytest.mark.parametrize("command", ["generate", "simulate", "compare-frf", "frf-body",
                                     "body-info", "fem", "sweep"])
def test_the_parser_of_one_command_is_the_full_parsers(command, capsys):
    """``main`` registers only the sub-command it runs: its ``--help`` and the usage error of
    a bad option read the same as with every sub-command registered (reference: the full
    parser of :func:`build_parser`)."""

    def output(parser, words):
        with pytest.raises(SystemExit):
            parser.parse_args(words)
        out = capsys.readouterr()
        return out.out + out.err

    assert len(build_parser(command)._subparsers._group_actions[0].choices) == 1
    for words in ([command, "--help"], [command, "--no-such-option"]):
        assert output(build_parser(command), words) == output(build_parser(), words)
    assert "compare-frf" in output(build_parser("--help"), ["--help"])


def test_a_missing_command_module_fails_loudly(monkeypatch):
    """A command module listed in COMMAND_MODULES that cannot be imported is a broken
    installation: building the parser raises (it used to be skipped silently)."""
    from neweul_py import cli

    monkeypatch.setattr(cli, "COMMAND_MODULES", (*cli.COMMAND_MODULES, "no_such_command"))
    with pytest.raises(ModuleNotFoundError, match="no_such_command"):
        cli.build_parser()


def test_negative_loss_factor_is_refused_like_a_negative_mass(capsys, tmp_path):
    """``-p eta=-1`` on a spring with ``loss_factor: eta``: a description refuses η < 0 at
    its defaults; the override makes the hysteretic matrix G = η k at the initial state
    negative (closed form for one spring), one error line."""
    desc = tmp_path / "sdof.yaml"
    desc.write_text(
        "name: sdof_loss\ngravity: [0, 0, 0]\nparameters: {m: 2.0, k: 1000.0, eta: 0.05}\n"
        "coordinates: {x: 0.0}\ninputs: {F: 0}\nframes: {cart: {translation: [x, 0, 0]}}\n"
        "bodies: {block: {frame: cart, mass: m, inertia: {diag: [0, 0, 0]}}}\n"
        "forces:\n  spring: {type: spring_damper, between: [ISYS, cart], points: "
        "[[-1, 0, 0], [0, 0, 0]], length: 1.0, stiffness: k, loss_factor: eta}\n"
        "  drive: {type: generalized, coordinate: x, value: F}\n")
    code, _, err = _run(capsys, "frf", str(desc), "--input", "F", "--response", "x",
                        "--f", "1,2", "-p", "eta=-1")
    assert code == 1 and err.count("\n") == 1, err
    assert "eta = -1" in err and "negative loss factor" in err
    code, _, err = _run(capsys, "frf", str(desc), "--input", "F", "--response", "x",
                        "--f", "1,2", "-p", "eta=0.1")
    assert code == 0, err


def test_version_is_the_installed_distributions():
    """Reference: the package metadata (importlib.metadata), which pyproject.toml sets."""
    from importlib.metadata import version

    import neweul_py

    assert neweul_py.__version__ == version("neweul-py")


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero", "directory"])
@pytest.mark.parametrize("command", ["interpolate --coordinate", "sweep --cases",
                                     "compare RESULT", "compare REFERENCE", "simulate FILE.py"])
def test_files_named_on_the_command_line_are_checked_before_reading(capsys, tmp_path, kind,
                                                                     command):
    """``interpolate --coordinate FIFO:…`` and ``sweep --cases FIFO`` hung, ``--cases
    /dev/zero`` filled memory: every file a command reads is checked to be a regular file
    first (docs/limits.md). Reference: POSIX file types; one error line, exit 1."""
    if kind == "fifo":
        path = tmp_path / "special.csv"
        os.mkfifo(path)
    else:
        path = tmp_path if kind == "directory" else Path(kind)
    good = str(FIXTURES / "two_mass.py")
    table = tmp_path / "table.csv"
    table.write_text("t,x\n0,0\n1,1\n")
    argv = {
        "interpolate --coordinate": ["interpolate", "a.npz", "b.npz", "--parameter", "p",
                                     "--coordinate", f"{path}:p:xi", "-o", "p.npz"],
        "sweep --cases": ["sweep", good, "--cases", str(path), "--task", "equilibrium"],
        "compare RESULT": ["compare", str(path), str(table)],
        "compare REFERENCE": ["compare", str(table), str(path)],
        "simulate FILE.py": ["simulate", str(path), "--t-end", "1"],
    }[command]
    if command == "simulate FILE.py" and kind == "fifo":
        os.rename(path, tmp_path / "special.py")
        argv[1] = str(tmp_path / "special.py")
    code, _, err = _run(capsys, *argv)
    assert code == 1, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert {"fifo": "FIFO", "/dev/zero": "character device", "directory": "directory"}[kind] \
        in err


@pytest.mark.parametrize("what", ["200 000 parameters", "20 000 terms"])
def test_huge_descriptions_are_one_error(capsys, tmp_path, what):
    """A description of 200 000 parameters or one expression of 20 000 terms (≈ 200 kB) ran
    for minutes; each is beyond a documented cap (docs/limits.md) and refused with one line,
    exit 1, nothing written. Reference: the counts written into the file."""
    body = "coordinates: {x: 0.1}\nframes: {f: {translation: [x, 0, 0]}}\n"
    if what.endswith("parameters"):
        text = ("name: many\nparameters:\n" + "".join(f"  p{i}: 1\n" for i in range(200_000))
                + body + "bodies: {b: {frame: f, mass: p0}}\n")
        message = "YAML nodes"
    else:
        terms = " + ".join(f"sin({k}*x)" for k in range(1, 20_001))
        text = ("name: long\nparameters: {m: 1}\n" + body + "bodies: {b: {frame: f, mass: m}}\n"
                f"forces: {{push: {{type: generalized, coordinate: x, value: '{terms}'}}}}\n")
        message = "more than the cap of"
    (tmp_path / "big.yaml").write_text(text)
    code, _, err = _run(capsys, "generate", str(tmp_path / "big.yaml"), "-o", "gen")
    assert code == 1 and err.count("\n") == 1 and message in err
    assert not (tmp_path / "gen").exists()
