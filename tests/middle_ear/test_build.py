"""``neweul middle-ear build``: the EMBS from nothing, atomically, and its bad input.

References: the FE sweep's own static solution (``static.csv``) for the body's static
outputs, the description loader for the retargeted description, and the files on disk after a
failed run (the previous complete build, untouched).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from neweul_py.api import load_description
from neweul_py.cli import main
from neweul_py.elastic.io.body_files import load_parametric_body
from neweul_py.elastic.io.fe_files import read_fe_model
from neweul_py.errors import NeweulError
from neweul_py.middle_ear.build import BuildOptions, build

#: A small build: refine 0, three working points, no refinement, slopes from ±20 Pa; it keeps
#: its slope FE models and basis cache for the rebuilds below.
SMALL = BuildOptions(refine=0, pressures=(-1000.0, 0.0, 1000.0), tol=0.0, generate=False,
                     keep_intermediate=True)


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    """One small build (seconds of CPU: a 1 332-DOF FE model at 9 working points)."""
    out = tmp_path_factory.mktemp("me") / "build"
    build(out, SMALL)
    return out


def test_the_build_holds_a_body_with_its_static_state_and_a_checked_description(small):
    """The body carries the static state of every sample: its static umbo output is the FE
    static solution's (``static.csv``, 12 digits); the description is loaded and names its
    body relative to itself (a moved build still loads); no module with ``generate=False``."""
    record = json.loads((small / "build.json").read_text())
    assert record["samples_Pa"] == [-1000.0, 0.0, 1000.0] and record["module"] is None
    pb = load_parametric_body(small / record["body"])
    rows = np.genfromtxt(small / "fem" / "static.csv", delimiter=",", names=True)
    umbo = pb.static.outputs[:, list(pb.output_names).index("umbo_uz")]
    np.testing.assert_allclose(umbo, rows["umbo_uz_m"], rtol=1e-10, atol=1e-18)
    assert pb.interpolation == "quintic-hermite" and pb.slopes is not None
    desc = small / "middle_ear.yaml"
    assert yaml.safe_load(desc.read_text())["elastic_bodies"]["tm"]["data"] == "embs/tm_air.npz"
    assert not (small / "generated").exists()


def test_the_default_body_is_galerkin_and_says_so(small, capsys):
    """The default basis is Galerkin: equal left and right node rows, ``two_sided`` false in
    the body file and ``build.json``, and ``neweul body-info`` (which states the projection
    from the node rows, not from the claim) prints it without a contradiction."""
    record = json.loads((small / "build.json").read_text())
    pb = load_parametric_body(small / record["body"])
    assert record["two_sided"] is False and not pb.two_sided
    assert np.array_equal(pb.V_kept, pb.W_kept)
    assert main(["body-info", str(small / record["body"])]) == 0
    out = capsys.readouterr().out
    assert "one-sided (Galerkin, W = V)" in out and "claims" not in out


def test_a_moved_build_still_loads(small, tmp_path):
    """The build directory moved as a whole: its description still finds the body."""
    moved = tmp_path / "moved"
    shutil.copytree(small, moved)
    assert "tm" in {b.name for b in load_description(moved / "middle_ear.yaml").elastic_bodies}


def test_the_body_names_its_fe_models_relative_to_itself(small):
    """Every sample and slope source of the body names an FE file that exists relative to
    the body file's folder and has the recorded fingerprint (reference: the FE files read
    back), never the build's temporary directory."""
    body_file = small / "embs" / "tm_air.npz"
    pb = load_parametric_body(body_file)
    sources = [*pb.sample_sources, *pb.slope_sources]
    assert len(sources) == 3 * 3
    for src in sources:
        assert not Path(src["file"]).is_absolute() and ".tmp" not in src["file"]
        fe = read_fe_model(body_file.parent / src["file"])
        assert fe.fingerprint == src["fingerprint"]


def test_a_failed_build_leaves_the_previous_one(small, tmp_path):
    """A working point beyond the model's validity (200 kPa: the static solution leaves the
    air space) stops the build with one error; the previous complete build is untouched and
    no temporary directory is left."""
    out = tmp_path / "b"
    shutil.copytree(small, out)
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    with pytest.raises(NeweulError):
        build(out, BuildOptions(refine=0, pressures=(-1000.0, 0.0, 200000.0), tol=0.0,
                                generate=False))
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before
    assert [p.name for p in tmp_path.iterdir()] == ["b"]


def _models(build_dir: Path) -> list[Path]:
    return sorted(build_dir.glob("fem*/model_dp*.npz"))


def test_the_sweeps_store_one_complete_model(small):
    """The build's sweeps hold one complete working point (the base in ``fem``, named by its
    ``sweep.json``); every other one, in every sweep, is a delta file of it."""
    base = json.loads((small / "fem" / "sweep.json").read_text())["fe_base"]
    complete = []
    for path in _models(small):
        with np.load(path) as z:
            record = json.loads(z["meta"].tobytes()).get("base")
        if record is None:
            complete.append(path)
        else:
            assert (path.parent / record["file"]).resolve() == (small / "fem" / base).resolve()
    assert complete == [small / "fem" / base] and len(_models(small)) > 3


def test_a_rebuild_reuses_the_working_points(small, tmp_path, monkeypatch):
    """A second build of the same refinement solves no FE model again (its working points
    are linked from the previous build, the delta files with their base: all still read, equal
    to the previous build's)."""
    out = tmp_path / "b"
    shutil.copytree(small, out)
    import neweul_py.middle_ear.working_points as wp

    def no_sweep(*args, **kwargs):
        raise AssertionError("an FE model was solved again")

    monkeypatch.setattr(wp, "pressure_sweep", no_sweep)
    build(out, SMALL)
    assert json.loads((out / "build.json").read_text())["samples_Pa"] == [-1000.0, 0.0, 1000.0]
    assert [p.relative_to(out) for p in _models(out)] == [
        p.relative_to(small) for p in _models(small)]
    for path in _models(out):
        a, b = read_fe_model(path), read_fe_model(small / path.relative_to(out))
        assert (a.K != b.K).nnz == 0 and (a.G != b.G).nnz == 0


def test_a_rebuild_with_other_parameters_solves_its_working_points(small, tmp_path,
                                                                   monkeypatch):
    """Other data (``BuildOptions.parameters``) make other FE models: nothing is reused, the
    sweep is solved with those data, and the failed rebuild leaves the previous build."""
    out = tmp_path / "d"
    shutil.copytree(small, out)
    import neweul_py.middle_ear.working_points as wp

    asked = []

    def sweep(pressures, params, **kwargs):
        asked.append(params)
        raise NeweulError("stop here")

    monkeypatch.setattr(wp, "pressure_sweep", sweep)
    with pytest.raises(NeweulError, match="stop here"):
        build(out, BuildOptions(**{**SMALL.__dict__, "parameters": {"k_chain": 1200.0}}))
    assert asked and asked[0].k_chain == 1200.0
    assert json.loads((out / "build.json").read_text()) == json.loads(
        (small / "build.json").read_text())


def test_a_pars_flaccida_refines_down_to_an_eighth_of_its_stiffening_pressure() -> None:
    """Its stiffness changes fourfold within ``±p_s`` (docs/equations-middle-ear.md §8): the
    refinement may split down to ``p_s/8`` and the slopes come from ``p_s/64`` (whole
    pascals, at least 1); without one, or with explicit values, the settings are as given."""
    pf = BuildOptions(parameters={"pf_compliance": 1e-12, "pf_stiffening_pressure": 400.0})
    assert (pf.min_interval, pf.slope_step) == (50.0, 6.0)
    steep = BuildOptions(parameters={"pf_compliance": 1e-12, "pf_stiffening_pressure": 40.0})
    assert (steep.min_interval, steep.slope_step) == (5.0, 1.0)
    assert (BuildOptions().min_interval, BuildOptions().slope_step) == (125.0, 20.0)
    own = BuildOptions(parameters={"pf_compliance": 1e-12}, min_interval=100.0, slope_step=0.0)
    assert (own.min_interval, own.slope_step) == (100.0, 0.0)
    with pytest.raises(NeweulError, match="slope step"):
        BuildOptions(min_interval=30.0, slope_step=20.0)


def test_build_options_refuse_an_unknown_parameter() -> None:
    """The Python path checks the names as the file reader does."""
    with pytest.raises(NeweulError, match="k_chian"):
        BuildOptions(parameters={"k_chian": 900.0})


def test_the_basis_is_cached_deflated_and_reused(small, tmp_path, monkeypatch):
    """The reduction basis is cached in ``embs/`` — the body's own basis ``R`` (reference),
    deflated, since a u–p basis is block-diagonal and mostly zeros — and a rebuild of the
    same refinement takes it instead of solving snapshots again."""
    cache = next((small / "embs").glob("basis*.npz"))
    with np.load(cache) as z:
        V = z["V"]
    body = load_parametric_body(small / "embs" / "tm_air.npz")
    np.testing.assert_array_equal(V, np.asarray(body.R))
    assert cache.stat().st_size < 0.5 * V.nbytes
    out = tmp_path / "c"
    shutil.copytree(small, out)
    import neweul_py.middle_ear.build as b

    def no_snapshots(*args, **kwargs):
        raise AssertionError("the basis was solved again")

    monkeypatch.setattr(b, "snapshot_basis", no_snapshots)
    build(out, SMALL)
    assert load_parametric_body(out / "embs" / "tm_air.npz").R.shape == V.shape


def test_a_build_removes_what_only_the_build_reads(small, tmp_path, monkeypatch):
    """Without ``keep_intermediate`` the slope FE models and the basis cache are gone after
    the build; the body still names each slope model with its fingerprint, and every FE
    model left reads (their delta bases are in ``fem``). Reference: the build that kept
    them (the same body, bit for bit)."""
    out = tmp_path / "lean"
    shutil.copytree(small, out)
    import neweul_py.middle_ear.working_points as wp

    def no_sweep(*args, **kwargs):
        raise AssertionError("an FE model was solved again")

    monkeypatch.setattr(wp, "pressure_sweep", no_sweep)     # all linked from the copy
    build(out, BuildOptions(**{**SMALL.__dict__, "keep_intermediate": False}))
    assert not list(out.glob("fem_slopes*")) and not list((out / "embs").glob("basis*"))
    assert list(small.glob("fem_slopes*")) and list((small / "embs").glob("basis*"))
    lean = load_parametric_body(out / "embs" / "tm_air.npz")
    kept = load_parametric_body(small / "embs" / "tm_air.npz")
    assert np.array_equal(lean.slopes["K"], kept.slopes["K"])
    assert lean.slope_sources == kept.slope_sources and all(
        s["fingerprint"] for s in lean.slope_sources)
    for path in _models(out):
        read_fe_model(path)


def test_a_lean_rebuild_keeps_a_sample_taken_from_a_slope_sweep(small, tmp_path):
    """A rebuild at −980 Pa, a slope model of the previous build (−1000 + 20 Pa), takes that
    working point from ``fem_slopes``: the lean build keeps that sweep, so the body's every
    sample source still reads (reference: the body's ``sample_sources``)."""
    out = tmp_path / "resample"
    shutil.copytree(small, out)
    build(out, BuildOptions(**{**SMALL.__dict__, "pressures": (-980.0, 0.0, 1000.0),
                               "keep_intermediate": False}))
    body = load_parametric_body(out / "embs" / "tm_air.npz")
    files = [out / "embs" / s["file"] for s in body.sample_sources]
    assert any("fem_slopes" in f.parent.name for f in files)
    for f in files:
        read_fe_model(f)


@pytest.mark.parametrize(("args", "where"), [
    (["--pressures=1000,0"], "pressures"),
    (["--refine", "7"], "--refine"),
    (["--slope-step", "20.5"], "slope step"),
    (["--basis", "oblique"], "--basis"),
    (["--rtol", "2"], "rtol"),
    (["--parameters", "no-such-ear.yaml"], "no-such-ear.yaml"),
])
def test_bad_options_are_one_error_and_write_nothing(args, where, tmp_path, capsys):
    """Decreasing working points, a refinement beyond the cap, a slope step that is no whole
    number of pascals: exit code ≠ 0, one line naming the option, no directory."""
    try:
        code = main(["middle-ear", "build", "--dir", str(tmp_path / "x"), "-q", *args])
    except SystemExit as exc:          # argparse: a usage error
        code = exc.code
    assert code != 0
    err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    assert where in err[-1]
    assert not (tmp_path / "x").exists()


def test_a_directory_of_other_data_is_refused(tmp_path):
    """A non-empty directory that is not a build is never replaced."""
    (tmp_path / "mine.txt").write_text("data")
    with pytest.raises(NeweulError, match=r"build\.json"):
        build(tmp_path, SMALL)
    assert (tmp_path / "mine.txt").read_text() == "data"
