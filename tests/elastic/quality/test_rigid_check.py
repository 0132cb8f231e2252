"""Rigid-body motion of FE models and bases (``neweul_py.elastic.quality.rigid_motion``), λ = 0 air
modes versus rigid motion in ``reduce_modal(skip_rigid=True)`` and ``neweul reduce
--invariants``.

References: the rigid-body fields of a free 3-D beam span the null space of its stiffness
(6 fields); a string with fixed ends closing an air cavity (``fe_builders.membrane_cavity``)
has no rigid motion, and its single λ = 0 mode is the constant cavity pressure (the dense
eigen-solution of the full pencil, pressure DOFs constant).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from beam_fe import beam
from fe_builders import membrane_cavity

from neweul_py.cli import main
from neweul_py.elastic import reduce_modal, stability, write_fe_model
from neweul_py.elastic.quality.rigid_motion import free_rigid_fields, repeated_rigid_fields
from neweul_py.elastic.reductors.modal import add_static_correction, modal_bases


def test_free_beam_has_six_rigid_fields_and_a_clamped_string_none():
    """Free beam: 6 free rigid fields, all repeated by a basis with the λ = 0 modes, none
    by the elastic modes (skip_rigid); the supported string–cavity model: none at all."""
    b = beam(12)
    assert free_rigid_fields(b.fe).shape[1] == 6
    assert repeated_rigid_fields(b.fe, reduce_modal(b.fe, modes=10, store_bases=True).V) == 6
    assert repeated_rigid_fields(b.fe, reduce_modal(b.fe, modes=4, skip_rigid=True,
                                                    store_bases=True).V) == 0
    assert free_rigid_fields(membrane_cavity(0.3)).shape[1] == 0


def test_skip_rigid_with_static_correction_of_a_closed_cavity_is_stable():
    """skip_rigid drops the closed cavity's λ = 0 mode (constant pressure, as the dense
    pencil says); the static correction is deflated of it, so the body stays stable, and
    without the skip the λ = 0 mode is kept (its pressure part constant)."""
    fe = membrane_cavity(0.3)
    lam = np.sort(sla.eigvals(fe.K.toarray(), fe.M.toarray()).real)
    assert abs(lam[0]) < 1e-6 * lam[1]
    a = reduce_modal(fe, modes=8, static_correction=True, store_bases=True)
    assert np.sum(a.eigenvalues == 0.0) == 1
    p = a.V[fe.dof_kind == "p", int(np.flatnonzero(a.eigenvalues == 0)[0])]
    np.testing.assert_allclose(p, p.mean(), rtol=1e-8)
    b = reduce_modal(fe, modes=8, static_correction=True, skip_rigid=True)
    assert np.all(b.eigenvalues > 0) and stability(b).stable and stability(a).stable


def test_cli_invariants_of_a_supported_up_body(tmp_path, capsys):
    """`reduce --invariants` of the supported string–cavity model passes with and without
    --skip-rigid (no rigid-motion check is needed) and reports no right-half-plane pole;
    the free beam is refused naming --skip-rigid only when it is not given, and
    --fixed-frame skips the check."""
    model = tmp_path / "mc.npz"
    write_fe_model(membrane_cavity(0.3), model)
    out = tmp_path / "body.npz"
    for extra in ([], ["--skip-rigid"]):
        assert main(["reduce", str(model), "--modes", "8", "--static-correction",
                     "--invariants", *extra, "-o", str(out)]) == 0
        cap = capsys.readouterr()
        assert "no rigid-motion check needed" in cap.err and "stable" in cap.out
        assert "right-half-plane" not in cap.out
    beam_model = tmp_path / "beam.npz"
    write_fe_model(beam(12).fe, beam_model)
    bad = tmp_path / "bad.npz"
    assert main(["reduce", str(beam_model), "--modes", "8", "--invariants", "-o",
                 str(bad)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "repeat the rigid motion" in err and "reduce with --skip-rigid" in err
    assert not bad.exists()
    assert main(["reduce", str(beam_model), "--modes", "8", "--invariants", "--fixed-frame",
                 "-o", str(out)]) == 0
    assert "fixed frame" in capsys.readouterr().err


def test_skip_rigid_static_correction_of_a_free_beam_is_stable_and_floating():
    """Free beam with a tip force and a tip displacement output, skip_rigid + static
    correction (one- and two-sided): the attachment vectors are deflated of the skipped
    λ = 0 modes (inertia relief), so the basis repeats no rigid motion (the floating-frame mass
    matrix stays regular) and the body is stable; the same vectors without the deflation
    repeat a rigid motion (the shifted solve keeps the rigid share of the tip force)."""
    fe = beam(12).fe
    tip = fe.n_dofs - 4                       # uz of the last node
    fe = fe.with_(inputs={"f": ((tip, 1.0),)}, outputs={"y": ((tip, 1.0),)})
    for two in (True, False):
        b = reduce_modal(fe, modes=4, skip_rigid=True, static_correction=True,
                         two_sided=two, store_bases=True)
        assert b.order == 5
        assert repeated_rigid_fields(fe, b.V) == 0
        assert stability(b).stable
    V, W, _, si = modal_bases(fe, modes=4, skip_rigid=True)
    X, _ = add_static_correction(fe, V, W, si)
    assert repeated_rigid_fields(fe, X) == 1
