"""The analysis sub-commands: files written, one-line errors with exit code 1.

References: the same numbers through the Python API (which the other tests check against closed
forms), and the file formats the issue prescribes.
"""

from __future__ import annotations

import csv
import importlib.util

import numpy as np
import pytest
from _analysis_helpers import FIXTURES, load_fixture

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import LinearModel, linearize
from neweul_py.analysis.modes import modes
from neweul_py.cli import main


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_equilibrium_command(capsys, tmp_path):
    code, out, _ = _run(capsys, "equilibrium", str(FIXTURES / "spring_pendulum.py"),
                        "-o", str(tmp_path / "eq.csv"))
    assert code == 0
    ref = equilibrium(load_fixture("spring_pendulum")).y[0]
    rows = list(csv.reader((tmp_path / "eq.csv").open()))
    assert rows[0] == ["name", "value"]
    assert float(rows[1][1]) == pytest.approx(ref, abs=1e-14)
    assert "phi" in out


def test_linearize_command_writes_npz(capsys, tmp_path):
    code, _, _ = _run(capsys, "linearize", str(FIXTURES / "cartesian_pendulum.py"),
                      "--at", "equilibrium", "-o", str(tmp_path / "lin.npz"))
    assert code == 0
    lin = LinearModel.load(tmp_path / "lin.npz")
    mod = load_fixture("cartesian_pendulum")
    ref = linearize(mod, equilibrium(mod))
    np.testing.assert_allclose(lin.Q, ref.Q, rtol=1e-12)
    assert lin.coordinates == ("x",)


def test_modes_command_csv(capsys, tmp_path):
    code, _, _ = _run(capsys, "modes", str(FIXTURES / "two_mass.py"), "--at", "initial",
                        "-o", str(tmp_path / "modes.csv"))
    assert code == 0
    rows = list(csv.reader((tmp_path / "modes.csv").open()))
    assert rows[0][:2] == ["frequency_hz", "damping_ratio"]
    ref = modes(load_fixture("two_mass"), y0=[0.0, 0.0])
    np.testing.assert_allclose([float(r[0]) for r in rows[1:]], ref.frequency_hz, rtol=1e-12)


def test_frf_command_csv_and_plot(capsys, tmp_path):
    code, _, _ = _run(capsys, "frf", str(FIXTURES / "two_mass.py"), "--input", "F1",
                      "--output", "pos2", "--f", "10:10000:400", "--log",
                      "--plot", str(tmp_path / "bode.png"), "-o", str(tmp_path / "frf.csv"))
    assert code == 0
    rows = list(csv.reader((tmp_path / "frf.csv").open()))
    assert rows[0] == ["frequency_hz", "magnitude", "phase_deg"]
    assert len(rows) == 401
    assert (tmp_path / "bode.png").stat().st_size > 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["frf", "two_mass.py", "--input", "F9", "--output", "pos2", "--f", "1:2:3"],
         "unknown input 'F9'; valid inputs: F1, F2"),
        (["frf", "two_mass.py", "--input", "F1", "--output", "nope", "--f", "1:2:3"],
         "unknown output 'nope'"),
        (["equilibrium", "cart_pendulum.py", "-p", "c=0", "-u", "F=0"],
         "no stiffness in the motion of coordinate(s) x"),
        (["equilibrium", "cart_pendulum.py", "-p", "c=0", "-u", "F=1"],
         "residual 1 (largest in the equation of x); last iterate x="),
        (["simulate", "two_mass.py", "--t-end", "1", "-p", "m2=0"],
         "no inertia in the motion of coordinate(s) x2"),
        pytest.param(["frf", "missing.py", "--f", "1:2:3", "--plot", "bode.xyz"],
                     "bode.xyz: cannot write a plot as .xyz; formats: "),
        pytest.param(["simulate", "missing.py", "--t-end", "1", "--plot", "fig.txt"],
                     "fig.txt: cannot write a plot as .txt"),
        pytest.param(["compare-frf", "missing.json", "missing.npz", "--input", "a", "--output",
                      "b", "--plot", "cmp.gnu"], "cmp.gnu: cannot write a plot as .gnu"),
        (["modes", "missing.py", "-o", "modes.txt"],
         "modes.txt: modes are written as .csv or .npz, not .txt"),
        (["frf", "missing.py", "--f", "1:2:3", "-o", "frf.json"],
         "frf.json: frequency responses are written as .csv or .npz"),
        (["linearize", "missing.py", "-o", "lin.txt"],
         "lin.txt: linear models are written as .npz, not .txt"),
        (["equilibrium", "missing.py", "-o", "eq.dat"],
         "eq.dat: equilibria are written as .csv or .npz"),
        (["simulate", "slider_crank.py", "--t-end", "1", "--independent", "phi", "s"],
         "independent coordinates phi, s do not fix the others"),
        (["linearize", "slider_crank.py", "--at", "initial"], "rest points"),
        (["equilibrium", "missing.py"], "missing.py"),
    ],
)
def test_errors_are_one_line_exit_1(capsys, argv, message):
    """Bad suffixes are refused before anything is computed: with FILE missing.py the error is
    about the file name, not about the missing module."""
    argv = [argv[0], str(FIXTURES / argv[1]), *argv[2:]]
    code, _, err = _run(capsys, *argv)
    assert code == 1
    assert err.count("\n") == 1
    assert message in err


def _two_mass_frequencies() -> np.ndarray:
    """|λ|/2π of the roots of det Z(s) of the two-mass oscillator (fixtures/two_mass.py)."""
    m1, m2, k1, k2, d1, d2 = load_fixture("two_mass").default_parameters()
    det = np.polysub(np.polymul([m1, d1 + d2, k1 + k2], [m2, d2, k2]),
                     np.polymul([d2, k2], [d2, k2]))
    lam = np.roots(det)
    return np.sort(np.abs(lam[lam.imag > 0])) / (2 * np.pi)


def test_result_files_go_into_missing_directories(capsys, tmp_path):
    """Every result file is written atomically and its missing parent directories are made;
    the numbers are the closed-form ones (poles of the two-mass oscillator, its static
    equilibrium x = 0 without load)."""
    two = str(FIXTURES / "two_mass.py")
    out = tmp_path / "not" / "yet"
    assert _run(capsys, "modes", two, "--at", "initial", "-o", str(out / "m.csv"))[0] == 0
    rows = list(csv.reader((out / "m.csv").open()))
    np.testing.assert_allclose([float(r[0]) for r in rows[1:]], _two_mass_frequencies(),
                               rtol=1e-10)
    assert _run(capsys, "modes", two, "--at", "initial", "-o", str(out / "m.npz"))[0] == 0
    with np.load(out / "m.npz") as f:
        np.testing.assert_allclose(f["frequency_hz"], _two_mass_frequencies(), rtol=1e-10)
    assert _run(capsys, "linearize", two, "-o", str(out / "a" / "lin.npz"))[0] == 0
    np.testing.assert_allclose(LinearModel.load(out / "a" / "lin.npz").Q,
                               [[2.9e4, -9.0e3], [-9.0e3, 9.0e3]], rtol=1e-14)  # [[k1+k2,-k2],..]
    assert _run(capsys, "equilibrium", two, "-o", str(out / "b" / "eq.npz"))[0] == 0
    with np.load(out / "b" / "eq.npz") as f:
        np.testing.assert_allclose(f["y"], [0.0, 0.0], atol=1e-15)
    code, _, _ = _run(capsys, "frf", two, "--input", "F1", "--output", "x2", "--f", "1:100:5",
                      "-o", str(out / "c" / "frf.npz"))
    assert code == 0
    with np.load(out / "c" / "frf.npz") as f:
        m1, m2, k1, k2, d1, d2 = load_fixture("two_mass").default_parameters()
        s = 2j * np.pi * f["frequency_hz"]
        cpl = d2 * s + k2
        ref = cpl / ((m1 * s**2 + (d1 + d2) * s + k1 + k2) * (m2 * s**2 + d2 * s + k2) - cpl**2)
        np.testing.assert_allclose(f["H"][:, 0, 0], ref, rtol=1e-10)
    if importlib.util.find_spec("matplotlib") is not None:
        code, _, _ = _run(capsys, "frf", two, "--input", "F1", "--output", "x2", "--f",
                          "1:100:5", "--plot", str(out / "d" / "bode.svg"))
        assert code == 0 and (out / "d" / "bode.svg").read_text().lstrip().startswith("<?xml")
    assert not list(tmp_path.rglob("*.tmp"))


def test_write_errors_are_one_line(capsys, tmp_path, monkeypatch):
    """An OSError while writing (here: a full disk) is one line, exit 1; a target that is a
    directory is refused before the work."""
    import errno

    modes_module = importlib.import_module("neweul_py.analysis.modes")

    (tmp_path / "modes.csv").mkdir()
    code, _, err = _run(capsys, "modes", str(FIXTURES / "two_mass.py"), "--at", "initial",
                        "-o", str(tmp_path / "modes.csv"))
    assert code == 1
    assert err == f"neweul modes: error: {tmp_path / 'modes.csv'}: a directory, not a file\n"

    def full(path, data):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(modes_module, "atomic_write", full)
    code, _, err = _run(capsys, "modes", str(FIXTURES / "two_mass.py"), "--at", "initial",
                        "-o", str(tmp_path / "m.csv"))
    assert code == 1
    assert err.count("\n") == 1 and "No space left on device" in err


def test_bugs_keep_their_traceback(monkeypatch):
    """Only NeweulError and OSError become one line; anything else is a bug."""
    from neweul_py.commands import modes as modes_command

    def broken(args):
        raise ValueError("a bug")

    monkeypatch.setattr(modes_command, "run", broken)
    with pytest.raises(ValueError, match="a bug"):
        main(["modes", str(FIXTURES / "two_mass.py")])


def test_parser_and_generated_modules_need_no_sympy(tmp_path):
    """Building the parser and running the analysis commands on a generated module import no
    symbolic layer; the CLI's --form choices are the API's forms."""
    import subprocess
    import sys
    import textwrap

    from neweul_py.api import FORMS
    from neweul_py.commands import FORMS as CLI_FORMS

    assert CLI_FORMS == FORMS
    code = textwrap.dedent(f"""
        import sys
        sys.modules["sympy"] = None
        from neweul_py.cli import main
        two = {str(FIXTURES / "two_mass.py")!r}
        assert main(["frf", two, "--input", "F1", "--output", "x2", "--f", "1:2:2"]) == 0
        assert main(["modes", two, "--at", "initial"]) == 0
        assert main(["simulate", two, "--t-end", "0.01", "-o", {str(tmp_path / "s.csv")!r}]) == 0
        assert not any(m.startswith(("neweul_py.equations", "neweul_py.codegen",
                                     "neweul_py.description", "neweul_py.api"))
                       for m in sys.modules)
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip().endswith("ok")


def test_simulate_keeps_the_given_initial_state_of_a_closed_loop(capsys, tmp_path):
    """The slider–crank starts exactly at its given phi = 0.5, d_phi = 8.0 (the dependent
    coordinates follow); with --independent s the slider keeps s = 0.37, d_s = 0 and phi solves
    the loop closure s = r cos phi + √(l² − r² sin² phi) (hand computation)."""
    sc = str(FIXTURES / "slider_crank.py")
    assert _run(capsys, "simulate", sc, "--t-end", "0.01", "--n-out", "2",
                "-o", str(tmp_path / "a.csv"))[0] == 0
    rows = list(csv.reader(line for line in (tmp_path / "a.csv").open()
                           if not line.startswith("#")))
    first = dict(zip(rows[0], map(float, rows[1]), strict=True))
    assert (first["phi"], first["d_phi"]) == (0.5, 8.0)
    assert _run(capsys, "simulate", sc, "--t-end", "0.01", "--n-out", "2", "--independent", "s",
                "-o", str(tmp_path / "b.csv"))[0] == 0
    rows = list(csv.reader(line for line in (tmp_path / "b.csv").open()
                           if not line.startswith("#")))
    first = dict(zip(rows[0], map(float, rows[1]), strict=True))
    assert (first["s"], first["d_s"]) == (0.37, 0.0)
    r, l, phi = 0.1, 0.3, first["phi"]
    assert r * np.cos(phi) + np.sqrt(l**2 - (r * np.sin(phi)) ** 2) == pytest.approx(0.37,
                                                                                     abs=1e-13)


def test_modes_of_the_slider_crank_from_its_initial_state(capsys):
    """``neweul modes`` finds the stable equilibrium from the initial state (continuation) and
    its mode equals the root of m(φ) λ² + c(φ) λ + k(φ) of the minimal model."""
    from _slider_crank_reference import build

    code, out, _ = _run(capsys, "modes", str(FIXTURES / "slider_crank.py"))
    assert code == 0
    ref = build(dict(load_fixture("slider_crank").PARAMETERS))
    phi = equilibrium(load_fixture("slider_crank")).y[0]
    lam = np.roots([ref.mass(phi), ref.damping(phi), ref.stiffness(phi)])
    f_ref = abs(lam[0]) / (2 * np.pi)
    assert float(out.splitlines()[1].split()[1]) == pytest.approx(f_ref, rel=1e-5)


def test_modes_warns_at_an_unstable_operating_point(capsys, tmp_path):
    """The inverted equilibrium of the spring pendulum: the warning names the positive real
    eigenvalue (closed form as in test_frf_modes) and the CSV has no oscillating mode."""
    m, l, g, k, a, b, d = load_fixture("spring_pendulum").default_parameters()
    phi = np.arctan2(k * a, m * g - k * b) + np.pi
    k_eff = k * l * (a * np.sin(phi) - b * np.cos(phi)) + m * g * l * np.cos(phi)
    lam = (-d + np.sqrt(d * d - 4 * m * l * l * k_eff)) / (2 * m * l * l)
    code, _, err = _run(capsys, "modes", str(FIXTURES / "spring_pendulum.py"),
                        "--start", f"phi={phi + 0.05}", "-o", str(tmp_path / "m.csv"))
    assert code == 0
    assert err.startswith("neweul modes: warning: the operating point is unstable: "
                          f"eigenvalue(s) with positive real part {lam:+.6g} (aperiodic")
    assert err.count("\n") == 1
    assert len((tmp_path / "m.csv").read_text().splitlines()) == 1
