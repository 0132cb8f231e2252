"""The middle-ear FE model: coupled pencil, static nonlinearity, sweep output and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neweul_py.cli import main
from neweul_py.errors import DataError, ModelError, SolverError
from neweul_py.fem.mesh import cone_membrane, extrude_tets
from neweul_py.fem.middle_ear import (
    MiddleEarParameters,
    build_middle_ear,
    parse_pressures,
    pressure_sweep,
    solve_static,
    static_summary,
    working_point_model,
)
from neweul_py.fem.nonlinear import NewtonOptions


@pytest.fixture(scope="module")
def coarse():
    me = build_middle_ear(refine=0)
    states = solve_static(me, [-4000.0, -2000.0, -1000.0, 0.0, 1000.0, 2000.0, 4000.0])
    return me, states


def _lowest(fe, k=16, f_shift=100.0):
    sigma = -((2 * np.pi * f_shift) ** 2)
    lu = spla.splu((fe.K - sigma * fe.M).tocsc())
    op = spla.LinearOperator(fe.K.shape, matvec=lambda x: lu.solve(fe.M @ x))
    mu, v = spla.eigs(op, k=k, which="LM")
    return sigma + 1.0 / mu, v


def test_model_structure_and_dofs(coarse):
    """The working-point model is an up-coupled FEModel with named inputs/outputs and the
    block structure of Eq. (2) (validated by FEModel itself)."""
    me, states = coarse
    fe = working_point_model(me, states[3])
    counts = me.dof_counts()
    assert fe.kind == "up-coupled" and fe.n_dofs == counts["total"]
    assert counts["tm_displacement"] == 3 * (me.tm.points.shape[0] - me.tm.boundary.size)
    assert {"canal_volume_acceleration"} <= set(fe.inputs)
    assert {"probe_pressure", "umbo_uz", "tm_volume_displacement"} <= set(fe.outputs)
    man = [n for n in fe.inputs if n.startswith("manubrium.")]
    assert len(man) == 3 * me.tm.line.size
    # the entrance load integrates to ρ (unit volume acceleration over the entrance area)
    w = sum(wt for _, wt in fe.inputs["canal_volume_acceleration"])
    assert w == pytest.approx(me.params.rho_air, rel=1e-12)
    assert sum(wt for _, wt in fe.outputs["probe_pressure"]) == pytest.approx(1.0)


def test_coupling_matches_static_pressure_convention(coarse):
    """A uniform canal pressure P acts on the TM as the static Δp = P does (C·1 = ∂V/∂u), a
    uniform cavity pressure as Δp = −P; and the λ = 0 left null vectors of the transposed
    problem are [0; 1_canal], [0; 1_cavity] (equations.md §3)."""
    me, states = coarse
    fe = working_point_model(me, states[5])
    nu, nc = me.n_u, me.canal.points.shape[0]
    k_up = fe.K[:nu][:, nu:]  # = −C
    grad_v = np.zeros(fe.n_dofs)
    for i, w in fe.outputs["tm_volume_displacement"]:
        grad_v[i] = w
    ones_canal = np.r_[np.ones(nc), np.zeros(me.n_p - nc)]
    np.testing.assert_allclose(-k_up @ ones_canal, grad_v[:nu], atol=1e-12 * np.abs(grad_v).max())
    np.testing.assert_allclose(
        -k_up @ (1.0 - ones_canal), -grad_v[:nu], atol=1e-12 * np.abs(grad_v).max()
    )
    for w_p in (ones_canal, 1.0 - ones_canal):
        w = np.r_[np.zeros(nu), w_p]
        assert np.abs(fe.K.T @ w).max() < 1e-9 * abs(fe.K).max()


def test_default_model_size():
    """Default refinement: tens of thousands of DOFs (mesh only, no solve)."""
    me = build_middle_ear()
    assert 10_000 < me.dof_counts()["total"] < 100_000


@pytest.mark.parametrize("index", [0, 3, 6])
def test_coupled_pencil_real_nonnegative_and_left_vectors(coarse, index):
    """(K − λM) v = 0 has real λ ≥ 0 and [ρλu; p] is a left eigenvector (equations.md §3)."""
    me, states = coarse
    fe = working_point_model(me, states[index])
    lam, v = _lowest(fe)
    scale = np.abs(lam).max()
    assert np.abs(lam.imag).max() < 1e-8 * scale
    assert lam.real.min() > -1e-8 * scale
    # two closed air volumes: two λ = 0 (u–p static) modes
    assert np.sum(np.abs(lam) < 1e-6 * scale) == 2
    nu = me.n_u
    for j in np.flatnonzero(np.abs(lam) > 1e-6 * scale)[:6]:
        lj, vj = lam[j].real, v[:, j].real
        w = np.concatenate([fe.density * lj * vj[:nu], vj[nu:]])
        left = fe.K.T @ w - lj * (fe.M.T @ w)
        assert np.linalg.norm(left) < 1e-8 * np.linalg.norm(fe.K.T @ w)


def test_static_volume_displacement_is_nonlinear(coarse):
    """ΔV(Δp): nonlinear, stiffening with |Δp| (secant compliance falls) on both sides, and not
    odd in Δp (|ΔV(−p)| ≠ |ΔV(p)|)."""
    me, states = coarse
    rows = [static_summary(me, s) for s in states]
    dp = np.array([r["dp_Pa"] for r in rows])
    dv = np.array([r["volume_displacement_m3"] for r in rows])
    assert np.all(np.sign(dv) == np.sign(dp))
    secant = {p: v / p for p, v in zip(dp, dv, strict=True) if p != 0}
    assert secant[4000.0] < 0.9 * secant[1000.0]
    assert secant[-4000.0] < 0.9 * secant[-1000.0]
    assert abs(abs(dv[0]) - abs(dv[-1])) > 0.05 * abs(dv[-1])
    # umbo moves with the pressure
    uz = np.array([r["umbo_uz_m"] for r in rows])
    assert np.all(np.sign(uz) == np.sign(dp))


def test_prestress_raises_tm_frequencies(coarse):
    """Tension stiffening: the first coupled TM mode is higher at +4 kPa than at 0."""
    me, states = coarse

    def first(state):
        lam = _lowest(working_point_model(me, state), k=6)[0].real
        return np.sort(lam)[2]

    assert first(states[6]) > 1.5 * first(states[3])


def test_sweep_cli_writes_all_files(tmp_path):
    out = tmp_path / "sweep"
    rc = main(["fem", "middle-ear", "--pressures", "-2000:2000:3", "-o", str(out), "--refine", "0"])
    assert rc == 0
    manifest = json.loads((out / "sweep.json").read_text())
    assert [w["dp_Pa"] for w in manifest["working_points"]] == [-2000.0, 0.0, 2000.0]
    for w in manifest["working_points"]:
        assert (out / w["file"]).is_file()
    lines = (out / "static.csv").read_text().splitlines()
    assert lines[0].startswith("dp_Pa,volume_displacement_m3") and len(lines) == 4
    try:
        from neweul_py.elastic.fe_io import read_fe_model
    except ImportError:
        return
    fe = read_fe_model(out / manifest["working_points"][0]["file"])
    assert fe.kind == "up-coupled"


@pytest.mark.slow
def test_default_sweep(tmp_path):
    """The default model (refine 2, ≈ 3·10⁴ DOFs) over −4000…4000 Pa, 9 working points."""
    res = pressure_sweep(np.linspace(-4000, 4000, 9), out_dir=str(tmp_path / "me"))
    dv = np.array([r["volume_displacement_m3"] for r in res.static])
    assert np.all(np.diff(dv) > 0)
    assert len(list((tmp_path / "me").glob("model_dp*.npz"))) == 9


def test_parse_pressures():
    assert parse_pressures("-4000:4000:9")[0] == -4000.0
    assert parse_pressures("0, 100") == [0.0, 100.0]
    with pytest.raises(ModelError):
        parse_pressures("1:2")


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"cavity_volume": 0.0}, "cavity_volume"),
        ({"cavity_volume": -1e-6}, "cavity_volume"),
        ({"cavity_volume": 1e-9}, "cavity_volume"),
        ({"tm_thickness": 0.01}, "tm_thickness"),
        ({"tm_depth": 0.01}, "tm_depth"),
        ({"tm_E": float("nan")}, "tm_E"),
    ],
)
def test_bad_geometry(change, key):
    with pytest.raises(ModelError, match=key):
        MiddleEarParameters(**change)


def test_bad_refinement():
    with pytest.raises(ModelError):
        build_middle_ear(refine=-1)


def test_mesh_failure_is_a_model_error():
    """An extrusion that inverts its elements is refused with a ModelError."""
    tm = cone_membrane(1.0, 0.0, 2)

    def fold(p, s):  # the far layer collapses onto the base
        return p + np.array([0.0, 0.0, 0.1 * np.sin(np.pi * s)])

    with pytest.raises(ModelError, match="degenerate or inverted"):
        extrude_tets(tm.points, tm.triangles, 2, fold)


def test_pressure_beyond_convergence_writes_nothing(tmp_path):
    """A straight cone with an (almost) free manubrium snaps through under negative Δp near
    −2.9 kPa (a limit point): load control cannot pass it, so the sweep raises SolverError
    naming the last converged load step, carries that state, and writes nothing."""
    out = tmp_path / "never"
    params = MiddleEarParameters(tm_bulge=0.0, k_chain=1.0)
    with pytest.raises(SolverError, match="last converged") as err:
        pressure_sweep([0.0, -4000.0], params=params, refine=0, out_dir=str(out))
    last = err.value.last_iterate
    assert -3500.0 < last.load < -2000.0
    assert np.all(np.isfinite(last.u))
    assert not out.exists()
    assert not list(tmp_path.iterdir())


def test_newton_step_limit_raises():
    """Too few iterations allowed: never an unconverged state returned as converged."""
    me = build_middle_ear(refine=0)
    opts = NewtonOptions(first_step=1000.0, max_step=1000.0, min_step=500.0, max_iter=1)
    with pytest.raises(SolverError, match="last converged"):
        solve_static(me, [4000.0], opts)


def test_refuses_to_overwrite_foreign_directory(tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(DataError):
        pressure_sweep([0.0], refine=0, out_dir=str(tmp_path))
    assert (tmp_path / "keep.txt").read_text() == "mine"
