"""The middle-ear body coupled with the chain by hand, against the unreduced FE model
(neweul_py/middle_ear/validation.py).

Reference: the unreduced FE model of each working point coupled with the same linearized
chain (:func:`~neweul_py.middle_ear.validation.reference_frf`, direct sparse solves).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from neweul_py.cli import main
from neweul_py.elastic.io.body_files import load_parametric_body
from neweul_py.middle_ear.build import BuildOptions, build
from neweul_py.middle_ear.embs import model_path
from neweul_py.middle_ear.study import transfer
from neweul_py.middle_ear.validation import (
    body_coupled_frf,
    chain_matrices,
    chain_module,
    coupled_poles,
    reference_frf,
)

PRESSURES = (-1000.0, 0.0, 1000.0)
F = np.geomspace(100.0, 6000.0, 25)


@pytest.fixture(scope="module", params=["two-sided", "galerkin"])
def built(request, tmp_path_factory) -> tuple[str, Path]:
    out = tmp_path_factory.mktemp("me") / "build"
    build(out, BuildOptions(refine=0, pressures=PRESSURES, tol=0.0, generate=False,
                            basis=request.param))
    return request.param, out


@pytest.mark.slow
def test_the_coupled_body_matches_the_coupled_fe_model_at_its_samples(built):
    """At every sample, 100 Hz–6 kHz: umbo, malleus and stapes velocity per probe pressure
    of the body + chain against the FE model + the same chain (refine 0, measured:
    two-sided order 123 ≤ 1.1e-3, Galerkin order 148 ≤ 6.9e-4, at 4–6 kHz), and no
    right-half-plane pole of the coupled EMBS at the samples or between them."""
    basis, out = built
    record = json.loads((out / "build.json").read_text())
    assert record["two_sided"] == (basis == "two-sided")
    pb = load_parametric_body(out / record["body"])
    mod = chain_module(out / "middle_ear.yaml", out / "fem", out / "gen_chain")
    for dp in PRESSURES:
        chain, own, node = chain_matrices(mod, dp)
        ref = transfer(reference_frf(mod, model_path(out / "fem", dp), dp, F), F)
        got = transfer(body_coupled_frf(chain, own, node, pb.at(dp), F), F)
        for key in ref:
            assert np.max(np.abs(got[key] - ref[key]) / np.abs(ref[key])) < 3e-3, (dp, key)
    for dp in (-1000.0, -500.0, 0.0, 500.0, 1000.0):
        chain, own, node = chain_matrices(mod, dp, "viscous")
        assert coupled_poles(chain, own, node, pb.at(dp)).size == 0


@pytest.mark.slow
def test_a_two_sided_build_is_recorded_and_shown_as_such(built, capsys):
    """``two_sided`` in ``build.json`` and the body file agrees with the node rows
    (``W_kept ≠ V_kept`` exactly for the two-sided basis), and ``neweul body-info``, which
    states the projection from the node rows, prints it without a contradiction."""
    basis, out = built
    record = json.loads((out / "build.json").read_text())
    pb = load_parametric_body(out / record["body"])
    two = basis == "two-sided"
    assert record["two_sided"] is two and pb.two_sided is two
    assert np.array_equal(pb.V_kept, pb.W_kept) is not two
    assert main(["body-info", str(out / record["body"])]) == 0
    text = capsys.readouterr().out
    assert ("two-sided (Petrov-Galerkin, W != V)" if two else "one-sided (Galerkin, W = V)") \
        in text and "claims" not in text
