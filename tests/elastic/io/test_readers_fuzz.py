"""Fuzzing the readers of elastic data (mutated reduced bodies, FE files (.mtx, npz), SID
files): reduced-body files with metadata and arrays of the wrong type (63 of 409
fuzzed bodies crashed), FE models as ``.npz`` and as a manifest with Matrix Market files, and
SID text files.

Property: a NeweulError (DataError) with one line, or a result — never another exception.
Reference: the error hierarchy of neweul_py/errors.py and the documented formats
(docs/reduced-body-format.md; the FE formats in neweul_py/elastic/io/fe_files.py).
``NEWEUL_FUZZ_LONG=1``: 20× longer.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from fe_builders import piston_duct
from fuzz_inputs import fuzz_settings, mutate_lines, mutate_npz, outcome
from hypothesis import given
from hypothesis import strategies as st

from neweul_py.elastic import read_fe_model, reduce_modal, write_fe_model
from neweul_py.elastic.io.body_files import load_reduced_body, save_reduced_body
from neweul_py.elastic.io.reader import read_elastic_data

SID = Path(__file__).resolve().parents[2] / "data" / "beam.SID_FEM"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    fe = piston_duct(12, damping=1.0)
    body = reduce_modal(fe, modes=4, store_bases=True).with_(
        parameters={"t": 1.0}, invariants={"m": np.array(1.5)})
    save_reduced_body(body, d / "body.npz")
    write_fe_model(fe, d / "fe.npz")
    write_fe_model(fe, d / "fe.json")
    manifest = json.loads((d / "fe.json").read_text())
    return {
        "dir": d,
        "body": dict(np.load(d / "body.npz")),
        "fe": dict(np.load(d / "fe.npz")),
        "mtx": {k: (d / v).read_text() for k, v in manifest["matrices"].items()},
        "manifest": manifest,
    }


@fuzz_settings(60)
@given(st.randoms(use_true_random=False))
def test_mutated_reduced_bodies(files, rng):
    path = files["dir"] / "m_body.npz"
    np.savez(path, **mutate_npz(files["body"], rng))
    outcome(lambda: load_reduced_body(path))
    outcome(lambda: read_elastic_data(path))


@fuzz_settings(60)
@given(st.randoms(use_true_random=False))
def test_mutated_fe_npz(files, rng):
    path = files["dir"] / "m_fe.npz"
    np.savez(path, **mutate_npz(files["fe"], rng))
    outcome(lambda: read_fe_model(path))


@fuzz_settings(40)
@given(st.sampled_from(["M", "K", "D"]), st.randoms(use_true_random=False))
def test_mutated_matrix_market_files(files, key, rng):
    d, manifest = files["dir"], files["manifest"]
    target = d / manifest["matrices"][key]
    target.write_text("\n".join(mutate_lines(files["mtx"][key].splitlines(), rng)) + "\n")
    try:
        outcome(lambda: read_fe_model(d / "fe.json"))
    finally:
        target.write_text(files["mtx"][key])


@fuzz_settings(60)
@given(st.randoms(use_true_random=False))
def test_mutated_sid_files(tmp_path_factory, rng):
    path = tmp_path_factory.mktemp("sid") / "b.SID_FEM"
    path.write_text("\n".join(mutate_lines(SID.read_text().splitlines(), rng)) + "\n")
    outcome(lambda: read_elastic_data(path))
