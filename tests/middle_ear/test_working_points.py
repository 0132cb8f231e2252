"""The FE working points of a build (neweul_py/middle_ear/working_points.py).

References: the FE models read directly from their files (``read_fe_model``): a handle or
the cache gives the same arrays, and reads a file only when its matrices are used.
"""

from __future__ import annotations

import numpy as np
import pytest

import neweul_py.middle_ear.working_points as working_points
from neweul_py.elastic.io.fe_files import read_fe_model
from neweul_py.elastic.parametric.snapshot_basis import check_same_mesh
from neweul_py.middle_ear.embs import model_path
from neweul_py.middle_ear.working_points import LazyModels, ModelHandle, WorkingPoints

POINTS = (0.0, 400.0, 800.0)


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    root = tmp_path_factory.mktemp("wp")
    WorkingPoints(root, 0, lambda *a, **k: None).solve("fem", POINTS)
    return root


@pytest.fixture
def reads(monkeypatch):
    """The files ``WorkingPoints`` reads, in order."""
    seen = []

    def counting(path):
        seen.append(path)
        return read_fe_model(path)

    monkeypatch.setattr(working_points, "read_fe_model", counting)
    return seen


def test_a_handle_is_the_model_and_reads_it_once(swept, reads) -> None:
    """Mesh, fingerprint and matrices of a handle are the model's; a mesh check and the
    fingerprint after the first read read nothing."""
    store = WorkingPoints(swept, 0, print)
    handles = LazyModels(store, POINTS, handles=True)
    direct = read_fe_model(model_path(swept / "fem", 400.0))
    h = handles[1]
    assert isinstance(h, ModelHandle) and h.n_dofs == direct.n_dofs
    assert h.fingerprint == direct.fingerprint
    assert (h.K != direct.K).nnz == 0 and np.array_equal(h.nodes, direct.nodes)
    assert len(reads) == 1
    store.models.clear()                     # the matrices are gone, the facts stay
    check_same_mesh(handles[1:2], [400.0])
    assert h.fingerprint == direct.fingerprint and len(reads) == 1
    check_same_mesh(handles, POINTS)
    assert len(reads) == 3                   # the two points not read before
    assert h.M.shape == direct.M.shape and len(reads) == 4    # the matrices: read again


def test_the_cache_keeps_pinned_models_within_its_cap(swept, reads) -> None:
    """With a cap below one model, only the model just read and the pinned ones stay."""
    store = WorkingPoints(swept, 0, print)
    store.cap = 1.0
    store.pinned.add(0.0)
    models = LazyModels(store, POINTS)
    for p in POINTS:
        assert models[POINTS.index(p)].source == str(model_path(swept / "fem", p))
    assert list(store.models) == [0.0, 800.0]
    models[0]
    assert len(reads) == 3                   # the pinned one was not read again


def test_a_handle_does_not_pickle(swept) -> None:
    """A handle stays in its process (a worker gets the model itself)."""
    import pickle

    with pytest.raises((TypeError, AttributeError, pickle.PicklingError)):
        pickle.dumps(ModelHandle(WorkingPoints(swept, 0, print), 0.0))
