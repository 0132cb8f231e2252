"""FE-model container validation and files: round trip, bad input.

References: the models are built in ``fe_builders`` (1-D linear elements); a round trip must
reproduce every array bit for bit; every bad file must raise a DataError naming the file and
the matrix/table.
"""

from __future__ import annotations

import json
import os
import warnings

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sps
from fe_builders import duct, piston_duct, random_up

from neweul_py.elastic import FEModel, read_fe_model, write_fe_model
from neweul_py.elastic.fe_model import up_block_deviations
from neweul_py.errors import DataError


def _same(a: FEModel, b: FEModel) -> None:
    for key in ("M", "K", "D"):
        x, y = getattr(a, key), getattr(b, key)
        assert (x is None) == (y is None)
        if x is not None:
            assert (x != y).nnz == 0
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.dof_node, b.dof_node)
    np.testing.assert_array_equal(a.dof_kind, b.dof_kind)
    assert a.inputs == b.inputs and a.outputs == b.outputs
    assert (a.kind, a.density, a.name, a.symmetric) == (b.kind, b.density, b.name, b.symmetric)


@pytest.mark.parametrize("suffix,fmt", [(".json", "mtx"), (".json", "hb"), (".npz", "mtx")])
@pytest.mark.parametrize("build", [duct, lambda: piston_duct(damping=3.0), random_up])
def test_round_trip_is_exact(tmp_path, build, suffix, fmt):
    fe = build()
    path = tmp_path / f"model{suffix}"
    write_fe_model(fe, path, matrix_format=fmt)
    back = read_fe_model(path)
    _same(fe, back)
    assert back.source == str(path)
    assert not list(tmp_path.glob(".*")), "temporary files left behind"


def test_manifest_paths_are_relative_to_the_manifest(tmp_path, monkeypatch):
    write_fe_model(duct(20), tmp_path / "sub" / "d.json")
    monkeypatch.chdir(tmp_path)
    assert read_fe_model("sub/d.json").n_dofs == 21


def test_input_and_output_matrices():
    fe = piston_duct()
    B, C = fe.B(), fe.C()
    assert B.shape == (fe.n_dofs, 1) and C.shape == (2, fe.n_dofs)
    assert B[0, 0] == 1.0 and C[0, fe.n_dofs - 1] == 1.0
    with pytest.raises(DataError, match="unknown input"):
        fe.B(["nope"])


# ---------------------------------------------------------------------- container errors
def _kw(fe: FEModel, **changes):
    kw = dict(M=fe.M, K=fe.K, D=fe.D, nodes=fe.nodes, dof_node=fe.dof_node,
              dof_kind=fe.dof_kind, inputs=fe.inputs, outputs=fe.outputs, kind=fe.kind,
              density=fe.density, symmetric=fe.symmetric, source="model.json")
    kw.update(changes)
    return kw


@pytest.mark.parametrize("changes,item,text", [
    (dict(K=sps.eye(5)), "K", "shape"),
    (dict(M=sps.random(21, 20, density=0.2)), "M", "square"),
    (dict(dof_node=np.arange(1, 21)), "dofs", "20 entries"),
    (dict(dof_node=np.full(21, 99)), "dofs", "node ids not in the node table"),
    (dict(dof_kind=np.full(21, "q")), "dofs", "unknown DOF kinds"),
    (dict(dof_node=np.ones(21, dtype=int)), "dofs", "more than once"),
    (dict(inputs={"f": ((21, 1.0),)}), "inputs.f", "DOF indices"),
    (dict(kind="fluid"), "kind", "unknown kind"),
    (dict(symmetric={"K": True}, K=sps.csr_matrix(np.triu(np.ones((21, 21))))), "K",
     "declared symmetric"),
])
def test_container_rejects_bad_data(changes, item, text):
    fe = duct(20)
    with pytest.raises(DataError, match=text) as exc:
        FEModel(**_kw(fe, **changes))
    assert exc.value.item == item and exc.value.file == "model.json"


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_container_rejects_nan_inf(bad):
    fe = duct(20)
    K = fe.K.copy()
    K.data[3] = bad
    with pytest.raises(DataError, match="NaN/Inf") as exc:
        FEModel(**_kw(fe, K=K))
    assert exc.value.item == "K"


def test_up_coupled_block_structure_is_checked():
    fe = piston_duct()
    with pytest.raises(DataError, match="density"):
        FEModel(**_kw(fe, density=None))
    with pytest.raises(DataError, match="ρ·Cᵀ"):  # wrong density: M_pu ≠ −ρ K_upᵀ
        FEModel(**_kw(fe, density=2 * fe.density))
    K = fe.K.tolil()
    K[5, 0] = 1.0  # a p–u entry in K
    with pytest.raises(DataError, match="p–u block of K") as exc:
        FEModel(**_kw(fe, K=K.tocsr()))
    assert exc.value.item == "K"
    M = fe.M.tolil()
    M[0, 3] = 1.0  # a u–p entry in M
    with pytest.raises(DataError, match="u–p block of M"):
        FEModel(**_kw(fe, M=M.tocsr()))


def test_up_block_deviations_measure_each_rule_relative_to_its_scale():
    """A valid u–p model deviates by round-off only; an entry put into a forbidden block, a
    loss coupling or an unsymmetric block shows as exactly its size over its matrix's (or
    block's) largest entry — the one measure the validation and the adjoint similarity use."""
    fe = piston_duct(damping=1.0)
    is_p = fe.dof_kind == "p"
    D = sps.csr_matrix(fe.D)
    dev = up_block_deviations(fe.M, fe.K, D, is_p, fe.density)
    assert max(dev.values()) <= 1e-15
    u, p = int(np.flatnonzero(~is_p)[0]), int(np.flatnonzero(is_p)[0])
    K = fe.K.tolil()
    K[p, u] = 0.5 * abs(fe.K).max()
    assert up_block_deviations(fe.M, K.tocsr(), D, is_p, fe.density)["K_pu"] == 0.5
    Dc = D.tolil()
    Dc[u, p] = 0.25 * abs(D).max()
    assert up_block_deviations(fe.M, fe.K, Dc.tocsr(), is_p, fe.density)["D_up"] == 0.25
    Mb = fe.M.tolil()
    pp = np.flatnonzero(is_p)
    Mb[pp[0], pp[1]] += 1e-3 * abs(fe.M[pp][:, pp]).max()
    got = up_block_deviations(Mb.tocsr(), fe.K, D, is_p, fe.density)["M_pp"]
    assert got == pytest.approx(1e-3, rel=1e-6)


# ---------------------------------------------------------------------- bad files
@pytest.fixture
def manifest(tmp_path):
    path = tmp_path / "m.json"
    write_fe_model(piston_duct(20, damping=1.0), path)
    return path


def _edit(path, **changes):
    meta = json.loads(path.read_text())
    meta.update(changes)
    path.write_text(json.dumps(meta))


def _companion(manifest, key):
    """The companion file the manifest names for ``key`` (M, K, D, nodes, dofs)."""
    meta = json.loads(manifest.read_text())
    return manifest.parent / (meta[key] if key in ("nodes", "dofs") else meta["matrices"][key])


def test_missing_file_is_named(tmp_path):
    with pytest.raises(DataError, match="not found"):
        read_fe_model(tmp_path / "none.json")


def test_invalid_json_names_the_line(manifest):
    manifest.write_text('{\n  "format": "neweul-fe",\n  oops\n}')
    with pytest.raises(DataError) as exc:
        read_fe_model(manifest)
    assert exc.value.line == 3 and exc.value.file == str(manifest)


@pytest.mark.parametrize("changes,item", [
    (dict(format="other"), "format"),
    (dict(version=3), "version"),
    (dict(matrices={"M": "<M>"}), "matrices"),
    (dict(matrices={"M": "<M>", "K": "missing.mtx"}), "K"),
    (dict(nodes=3), "nodes"),
])
def test_bad_manifest_entries(manifest, changes, item):
    if "matrices" in changes:
        m_name = _companion(manifest, "M").name
        changes = dict(matrices={k: v.replace("<M>", m_name)
                                 for k, v in changes["matrices"].items()})
    _edit(manifest, **changes)
    with pytest.raises(DataError) as exc:
        read_fe_model(manifest)
    assert exc.value.item == item


def test_nan_in_matrix_market_file_names_file_and_matrix(manifest):
    path = _companion(manifest, "K")
    K = scipy.io.mmread(path).tocsr()
    K.data[0] = np.nan
    scipy.io.mmwrite(path, K)
    with pytest.raises(DataError, match="NaN") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "K" and exc.value.file == str(path)


def test_garbage_matrix_file(manifest):
    _companion(manifest, "M").write_text("not a matrix\n")
    with pytest.raises(DataError, match="cannot read matrix") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "M"


def test_wrong_matrix_shape_is_named(manifest):
    path = _companion(manifest, "D")
    scipy.io.mmwrite(path, sps.eye(7, format="csr"))
    with pytest.raises(DataError, match="shape") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "D" and exc.value.file == str(path)


def test_dof_table_that_does_not_match_the_matrices(manifest):
    dofs = _companion(manifest, "dofs")
    lines = dofs.read_text().splitlines()
    dofs.write_text("\n".join(lines[:-1]) + "\n")  # one DOF too few
    with pytest.raises(DataError, match=r"permutation|DOFs listed") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "dofs" and exc.value.file == str(dofs)


def test_bad_csv_header_and_number(manifest):
    nodes = _companion(manifest, "nodes")
    text = nodes.read_text()
    nodes.write_text(text.replace("id,x,y,z", "id,x,y"))
    with pytest.raises(DataError, match="header") as exc:
        read_fe_model(manifest)
    assert exc.value.line == 1
    nodes.write_text(text.replace("\n3,", "\nthree,", 1))
    with pytest.raises(DataError, match="not a number") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "nodes" and exc.value.line == 4


def test_npz_with_pickled_object_array_is_rejected(tmp_path):
    path = tmp_path / "m.npz"
    write_fe_model(duct(10), path)
    data = dict(np.load(path))
    data["nodes"] = np.array([object()], dtype=object)
    np.savez(path, **data)  # allow_pickle default would be needed to read this
    with pytest.raises(DataError, match=r"unreadable array|pickle"):
        read_fe_model(path)


def test_interrupted_write_leaves_nothing_partial(tmp_path, monkeypatch):
    target = tmp_path / "m.npz"
    write_fe_model(duct(10), target)
    before = target.read_bytes()

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np.lib.format, "write_array", boom)
    with pytest.raises(KeyboardInterrupt):
        write_fe_model(duct(30), target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz"]
    monkeypatch.undo()

    monkeypatch.setattr(scipy.io, "mmwrite", boom)
    with pytest.raises(KeyboardInterrupt):
        write_fe_model(duct(30), tmp_path / "new.json")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz"]


@pytest.mark.parametrize("changes,item", [
    (dict(density="1.2"), "density"),        # a string, not a number
    (dict(density=[1.2]), "density"),
    (dict(density=True), "density"),         # a bool is not a density
    (dict(symmetric={"M": "no"}), "symmetric.M"),  # bool("no") would be True
    (dict(symmetric={"K": 1}), "symmetric.K"),
    (dict(name={"a": 1}), "name"),
])
def test_manifest_values_of_the_wrong_type(manifest, changes, item):
    """One DataError naming the manifest and the key, never a TypeError or a silent cast."""
    _edit(manifest, **changes)
    with pytest.raises(DataError) as exc:
        read_fe_model(manifest)
    assert exc.value.file == str(manifest) and exc.value.item == item
    assert "\n" not in str(exc.value)


def test_not_a_zip_npz_and_garbage_harwell_boeing_are_one_line_errors(manifest, tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_text("hello, I am not a zip file\n")
    with pytest.raises(DataError, match=r"not a valid \.npz file") as exc:
        read_fe_model(bad)
    assert exc.value.file == str(bad) and "pickle" not in str(exc.value)
    hb = tmp_path / "x.rua"
    hb.write_text("garbage\n")
    with pytest.raises(ValueError, match="\n"):  # scipy's own message spans two lines
        scipy.io.hb_read(str(hb))
    meta = json.loads(manifest.read_text())
    meta["matrices"]["M"] = "x.rua"
    manifest.write_text(json.dumps(meta))
    with pytest.raises(DataError, match="cannot read matrix") as exc:
        read_fe_model(manifest)
    assert exc.value.file == str(hb) and exc.value.item == "M"
    assert "\n" not in str(exc.value)


def test_empty_dof_table_is_an_error_without_a_warning(manifest):
    dofs = _companion(manifest, "dofs")
    dofs.write_text("index,node,kind\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's "loadtxt: input contained no data"
        with pytest.raises(DataError, match="no DOFs") as exc:
            read_fe_model(manifest)
    assert exc.value.file == str(dofs) and exc.value.item == "dofs"


def _edit_dof_rows(path, edit):
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    edit(rows)
    path.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")


@pytest.mark.parametrize("edit,text", [
    (lambda rows: rows[3].__setitem__(1, "999"), "node ids not in the node table"),
    (lambda rows: rows[3].__setitem__(2, "pp"), "unknown DOF kinds"),
    (lambda rows: rows[4].__setitem__(1, rows[3][1]), "more than once"),
])
def test_dof_map_errors_name_the_dof_file(manifest, edit, text):
    dofs = _companion(manifest, "dofs")
    _edit_dof_rows(dofs, edit)
    with pytest.raises(DataError, match=text) as exc:
        read_fe_model(manifest)
    assert exc.value.file == str(dofs) and exc.value.item == "dofs"


def test_symmetry_error_names_the_matrix_file(manifest):
    """piston_duct's K is unsymmetric (u–p coupling, Eq. (2)); declaring it symmetric fails
    in the .mtx that holds it."""
    _edit(manifest, symmetric={"K": True})
    with pytest.raises(DataError, match="declared symmetric") as exc:
        read_fe_model(manifest)
    assert exc.value.file == str(_companion(manifest, "K")) and exc.value.item == "K"


@pytest.mark.parametrize("fail_at", [1, 2, 3, 4, 5, 6])
def test_rewriting_a_manifest_never_mixes_old_and_new_files(tmp_path, monkeypatch, fail_at):
    """An exception at the k-th os.replace of a rewrite (companions 1–5, manifest 6) leaves
    the old model readable and identical, and the directory as it was."""
    path = tmp_path / "m.json"
    old = piston_duct(20, damping=1.0)
    write_fe_model(old, path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real, calls = os.replace, []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == fail_at:
            raise KeyboardInterrupt
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(KeyboardInterrupt):
        write_fe_model(piston_duct(30, damping=2.0), path)
    monkeypatch.undo()
    _same(old, read_fe_model(path))
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_rewriting_a_manifest_replaces_its_companions(tmp_path):
    """A successful rewrite reads back as the new model; the old companions are gone, files
    the writer did not make are left alone; the same model gives the same file names."""
    path = tmp_path / "m.json"
    write_fe_model(piston_duct(20, damping=1.0), path)
    first = sorted(p.name for p in tmp_path.iterdir())
    (tmp_path / "m.K.mtx").write_text("a user's file\n")
    new = piston_duct(30)
    write_fe_model(new, path)
    _same(new, read_fe_model(path))
    meta = json.loads(path.read_text())
    named = {*meta["matrices"].values(), meta["nodes"], meta["dofs"]}
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({"m.json", "m.K.mtx", *named})
    assert not named & set(first)
    write_fe_model(new, path)  # same content: same names, nothing else changes
    assert json.loads(path.read_text()) == meta


@pytest.mark.parametrize("suffix,fmt", [(".json", "mtx"), (".json", "hb"), (".npz", "mtx")])
def test_fingerprint_survives_files_and_sees_changes(tmp_path, suffix, fmt):
    """The fingerprint a reduced body records is the same for the model read back from any
    file form, and differs when a matrix entry, the DOF map or an input weight changes."""
    fe = piston_duct(20, damping=1.0)
    write_fe_model(fe, tmp_path / f"m{suffix}", matrix_format=fmt)
    assert read_fe_model(tmp_path / f"m{suffix}").fingerprint == fe.fingerprint
    K = fe.K.tolil()
    K[1, 1] *= 1 + 1e-15
    changed = [fe.with_(K=K.tocsr()), fe.with_(inputs={"force": ((0, 2.0),)}),
               fe.with_(nodes=fe.nodes + np.array([0, 0, 0, 1e-9])), fe.with_(name="other")]
    prints = [c.fingerprint for c in changed]
    assert all(p != fe.fingerprint for p in prints[:3]) and prints[3] == fe.fingerprint
