"""Fuzzing command-line options: random option values — numbers,
ranges, lists, names, suffixes — for the analysis and reduction commands on small models.

Property: exit 0 (a result), 1 (one error line) or 2 (argparse's usage and one error line),
never a traceback or an exception, and no partial output file. Reference: the exit-code rule
of neweul_py/cli.py. ``NEWEUL_FUZZ_LONG=1`` runs 20× longer.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from fuzz_inputs import fuzz_settings
from hypothesis import given
from hypothesis import strategies as st

from neweul_py.cli import main

ROOT = Path(__file__).resolve().parents[2]
TWO = str(ROOT / "tests" / "analysis" / "fixtures" / "two_mass.py")

NUMBERS = ["0", "1", "-1", "1e-3", "2.5", "nan", "inf", "-inf", "1e308", "1e400", "x", "",
           "1e9", "3.5", "-0"]
RANGES = ["1:10:5", "10:1:5", "nan:10:5", "1:10:1e9", "1:10:0", "1:2", "1,2,3", "-1:1:3",
          "0:1e300:2", ",", "1:10:2.5", "a:b:c"]
OPTIONS = {
    "simulate": [("--t-end", NUMBERS), ("--n-out", NUMBERS), ("--rtol", NUMBERS),
                 ("--atol", NUMBERS), ("-p", ["m1=" + n for n in NUMBERS] + ["zz=1", "m1"]),
                 ("--method", ["RK45", "Radau", "bogus"]), ("-o", ["r.csv", "r.npz", "r.txt"]),
                 ("--max-steps", NUMBERS)],
    "frf": [("--f", RANGES), ("-p", ["k1=" + n for n in NUMBERS]),
            ("-u", ["F1=" + n for n in NUMBERS]), ("--input", ["F1", "F9"]),
            ("--response", ["pos2", "nope"]), ("-o", ["h.csv", "h.npz", "h.json"]),
            ("--at", ["initial", "equilibrium"])],
    "modes": [("-p", ["m2=" + n for n in NUMBERS]), ("--at", ["initial", "equilibrium"]),
              ("-o", ["m.csv", "m.txt"]), ("--start", ["x1=" + n for n in NUMBERS])],
    "equilibrium": [("-p", ["k1=" + n for n in NUMBERS]), ("-u", ["F1=" + n for n in NUMBERS]),
                    ("--fix", ["x1", "zz"]), ("-o", ["e.csv", "e.dat"])],
}


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


@fuzz_settings(40)
@given(st.sampled_from(sorted(OPTIONS)), st.randoms(use_true_random=False))
def test_random_options(tmp_path_factory, capsys, command, rng):
    work = tmp_path_factory.mktemp("cli")
    argv = [command, TWO]
    if command == "simulate":
        argv += ["--t-end", "0.01"]
    if command == "frf":
        argv += ["--f", "1:10:3"]
    for _ in range(rng.randint(1, 3)):
        option, values = rng.choice(OPTIONS[command])
        value = rng.choice(values)
        argv += [option, str(work / value) if option == "-o" else value]
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    _, err = capsys.readouterr()
    assert code in (0, 1, 2), argv
    assert "Traceback" not in err
    if code == 1:
        assert err.count("\n") == 1, (argv, err)
    if code != 0:
        assert not any(p.suffix in (".csv", ".npz", ".txt", ".json", ".dat")
                       for p in work.iterdir()), argv
