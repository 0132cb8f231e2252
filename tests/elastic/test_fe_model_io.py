"""FE-model container validation and files (issue 3 items 1 and 6: round trip, bad input).

References: the models are built in ``fe_builders`` (1-D linear elements); a round trip must
reproduce every array bit for bit; every bad file must raise a DataError naming the file and
the matrix/table.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sps
from fe_builders import duct, piston_duct, random_up

from neweul_py.elastic import FEModel, read_fe_model, write_fe_model
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
    (dict(version=2), "version"),
    (dict(matrices={"M": "m.M.mtx"}), "matrices"),
    (dict(matrices={"M": "m.M.mtx", "K": "missing.mtx"}), "K"),
    (dict(nodes=3), "nodes"),
])
def test_bad_manifest_entries(manifest, changes, item):
    _edit(manifest, **changes)
    with pytest.raises(DataError) as exc:
        read_fe_model(manifest)
    assert exc.value.item == item


def test_nan_in_matrix_market_file_names_file_and_matrix(manifest):
    K = scipy.io.mmread(manifest.parent / "m.K.mtx").tocsr()
    K.data[0] = np.nan
    scipy.io.mmwrite(manifest.parent / "m.K.mtx", K)
    with pytest.raises(DataError, match="NaN") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "K" and exc.value.file.endswith("m.K.mtx")


def test_garbage_matrix_file(manifest):
    (manifest.parent / "m.M.mtx").write_text("not a matrix\n")
    with pytest.raises(DataError, match="cannot read matrix") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "M"


def test_wrong_matrix_shape_is_named(manifest):
    scipy.io.mmwrite(manifest.parent / "m.D.mtx", sps.eye(7, format="csr"))
    with pytest.raises(DataError, match="shape") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "D" and exc.value.file.endswith("m.D.mtx")


def test_dof_table_that_does_not_match_the_matrices(manifest):
    dofs = manifest.parent / "m.dofs.csv"
    lines = dofs.read_text().splitlines()
    dofs.write_text("\n".join(lines[:-1]) + "\n")  # one DOF too few
    with pytest.raises(DataError, match=r"permutation|DOFs listed") as exc:
        read_fe_model(manifest)
    assert exc.value.item == "dofs" and exc.value.file.endswith("m.dofs.csv")


def test_bad_csv_header_and_number(manifest):
    nodes = manifest.parent / "m.nodes.csv"
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

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(KeyboardInterrupt):
        write_fe_model(duct(30), target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz"]
    monkeypatch.undo()

    monkeypatch.setattr(scipy.io, "mmwrite", boom)
    with pytest.raises(KeyboardInterrupt):
        write_fe_model(duct(30), tmp_path / "new.json")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz"]
