"""Fuzzing the readers of tables and result files: the cases of a sweep (``--cases``), the
tables and results ``compare`` reads (CSV of any tool, our ``.npz`` results), and the result
files read back (simulation results, modes, frequency responses, linear models, sweep tables).

Each mutation starts from a valid file — lines dropped, duplicated, truncated, words replaced
by bad numbers (tests/fuzz_inputs.py ``mutate_lines``), bytes that are not UTF-8, NULs, cuts
and unclosed quotes (``mutate_bytes``), arrays and metadata of the wrong type
(``mutate_npz``). Property: a NeweulError with one line, or a result — never another
exception, never a hang. Reference: the error hierarchy of neweul_py/errors.py and the
documented formats (docs/analysis.md). ``NEWEUL_FUZZ_LONG=1``: 20× longer; benchmarks/
bench_fuzz.py ``--tables`` runs thousands.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fuzz_inputs import fuzz_settings, mutate_bytes, mutate_lines, mutate_npz, outcome
from hypothesis import given
from hypothesis import strategies as st

from neweul_py.analysis.compare_io import read_table
from neweul_py.analysis.frf import FrequencyResponse
from neweul_py.analysis.linearize import LinearModel
from neweul_py.analysis.modes import ModalResult
from neweul_py.analysis.results import load_npz
from neweul_py.analysis.sweep import SweepResult
from neweul_py.analysis.sweep_cases import read_cases

GENERATED = Path(__file__).resolve().parents[2] / "generated"
CSV_READERS = {"cases": read_cases, "compare table": read_table}
NPZ_READERS = {"results": load_npz, "modes": ModalResult.load,
               "frf": FrequencyResponse.load, "linear model": LinearModel.load,
               "sweep table": SweepResult.load, "compare": read_table}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Valid files of every kind, written by the package itself."""
    from neweul_py.analysis import frequency_response, linearize, load_generated, modes
    from neweul_py.analysis.simulate import simulate

    d = tmp_path_factory.mktemp("tables")
    module = load_generated(GENERATED / "quarter_car.py")
    res = simulate(module, 0.2, n_out=21)
    lin = linearize(module)
    out = {
        "cases": d / "cases.csv", "compare table": res.save(d / "result.csv"),
        "results": res.save(d / "result.npz"), "modes": modes(lin).save(d / "modes.npz"),
        "frf": frequency_response(lin, [1.0, 2.0, 5.0]).save(d / "frf.npz"),
        "linear model": lin.save(d / "lin.npz"),
        "sweep table": SweepResult(
            data={"case": np.arange(2), "m": np.array([1.0, 2.0]),
                  "ok": np.array([True, False]), "error": np.array(["", "singular"]),
                  "f1_hz": np.array([1.5, np.nan])},
            parameters=("m",), task="modes", model_name="x").save(d / "sweep.npz"),
    }
    out["cases"].write_text("ms,ks\n# mass and stiffness\n250,16000\n300,18000\n")
    out["compare"] = out["results"]
    return d, out


@fuzz_settings(120)
@given(st.sampled_from(sorted(CSV_READERS)), st.randoms(use_true_random=False),
       st.booleans())
def test_mutated_tables_read_or_fail_cleanly(files, kind, rng, bytewise):
    d, paths = files
    raw = Path(paths[kind]).read_bytes()
    data = (mutate_bytes(raw, rng) if bytewise else
            "\n".join(mutate_lines(raw.decode().splitlines(), rng)).encode())
    target = d / f"m_{kind.replace(' ', '_')}.csv"
    target.write_bytes(data)
    outcome(lambda: CSV_READERS[kind](target))


@fuzz_settings(120)
@given(st.sampled_from(sorted(NPZ_READERS)), st.randoms(use_true_random=False))
def test_mutated_result_files_read_or_fail_cleanly(files, kind, rng):
    d, paths = files
    with np.load(paths[kind]) as f:
        arrays = {k: f[k] for k in f.files}
    target = d / f"m_{kind.replace(' ', '_')}.npz"
    np.savez(target, **mutate_npz(arrays, rng, meta_key="__none__"))
    outcome(lambda: NPZ_READERS[kind](target))
