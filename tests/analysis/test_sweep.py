"""Parameter sweeps on a real Dask LocalCluster (neweul_py/analysis/sweep.py, sweep_cases.py,
sweep_tasks.py; neweul_py/sweep.py; ``neweul sweep``)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import distributed
import numpy as np
import pytest

from neweul_py.analysis import load_generated, simulate
from neweul_py.analysis.sweep import SweepResult, connect, sweep
from neweul_py.analysis.sweep_cases import grid, parse_parameter, product, read_cases
from neweul_py.cli import main
from neweul_py.errors import DataError, NeweulError

GENERATED = Path(__file__).resolve().parents[2] / "generated"
PENDULUM = GENERATED / "pendulum.py"


@pytest.fixture(scope="module")
def client():
    """Two in-process workers: a real scheduler and real workers, started in about a second."""
    import logging

    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    cl = distributed.Client(cluster)
    yield cl
    cl.close()
    cluster.close()


def test_case_specifications(tmp_path):
    """Reference: numpy.linspace and the Cartesian product written out by hand."""
    name, values = parse_parameter("m=0.5:2:4")
    assert name == "m" and np.allclose(values, [0.5, 1.0, 1.5, 2.0])
    assert grid({"a": [1, 2], "b": [3, 4]}) == [
        {"a": 1, "b": 3}, {"a": 1, "b": 4}, {"a": 2, "b": 3}, {"a": 2, "b": 4}]
    (tmp_path / "c.csv").write_text("l,g\n0.5,9.81\n1,1.62\n")
    assert product(read_cases(tmp_path / "c.csv"), [{"m": 2.0}]) == [
        {"l": 0.5, "g": 9.81, "m": 2.0}, {"l": 1.0, "g": 1.62, "m": 2.0}]
    (tmp_path / "bad.csv").write_text("l,g\n0.5,nan\n")
    with pytest.raises(DataError, match="row 2, column 'g'"):
        read_cases(tmp_path / "bad.csv")
    with pytest.raises(NeweulError, match="START:STOP:COUNT"):
        parse_parameter("m=1:2")


def test_modes_sweep_matches_closed_form_and_records_singular_cases(client, tmp_path):
    """Reference: the pendulum's natural frequency sqrt(g/l)/(2π), independent of m; m = 0
    makes the mass matrix singular — that case is recorded, the others still run."""
    cases = grid({"m": [0.0, 1.0], "l": [0.5, 1.0, 2.0]})
    res = sweep(PENDULUM, cases, "modes", client=client)
    ok = res.ok
    assert list(ok) == [False] * 3 + [True] * 3
    assert all("singular mass matrix" in msg for _, msg in res.failures)
    g = load_generated(PENDULUM).PARAMETERS["g"]
    f_ref = np.sqrt(g / res.data["l"][3:]) / (2 * np.pi)
    np.testing.assert_allclose(res.data["f1_hz"][3:], f_ref,
                               rtol=1e-10)
    import pandas as pd
    path = res.save(tmp_path / "modes.csv")
    frame = pd.read_csv(path)
    assert list(frame["ok"]) == [0, 0, 0, 1, 1, 1] and len(frame) == 6
    rec = np.genfromtxt(path, names=True, delimiter=",")
    np.testing.assert_allclose(rec["f1_hz"][3:], res.data["f1_hz"][3:])
    back = SweepResult.load(res.save(tmp_path / "modes.npz"))
    assert list(back.data["error"]) == list(res.data["error"])


def test_simulate_sweep_equals_a_plain_loop(client, monkeypatch):
    """Reference: the same simulations run one by one in this process (bit-identical), with
    the module's source shipped to the workers once (one broadcast scatter for 3 chunks)."""
    scattered: list[tuple[object, bool]] = []
    real_scatter = client.scatter

    def spy(data, **kw):
        scattered.append((data, kw.get("broadcast", False)))
        return real_scatter(data, **kw)

    monkeypatch.setattr(client, "scatter", spy)
    cases = grid({"l": [0.5, 1.0, 1.5, 2.0, 2.5]})
    res = sweep(PENDULUM, cases, "simulate", client=client, t_end=1.0, n_out=11,
                stats=("final", "max"), chunk_size=2)
    assert len(scattered) == 1 and scattered[0][1] is True
    assert scattered[0][0] == PENDULUM.read_text()
    mod = load_generated(PENDULUM)
    for k, case in enumerate(cases):
        ref = simulate(mod, 1.0, n_out=11, p=case)
        assert res.data["final_phi"][k] == ref.y[-1, 0]
        assert res.data["max_d_phi"][k] == ref.yd[:, 0].max()
    assert res.ok.all() and res.workers == 2


def _failing_task(module, p):
    """A user task whose integration fails for l < 0.75 (a stand-in for a diverging run)."""
    if p["l"] < 0.75:
        raise FloatingPointError("integration diverged")
    return {"twice_l": 2 * p["l"]}


def test_failing_user_task_is_recorded_and_progress_counts_cases(client):
    """Reference: the task's own arithmetic and the case count."""
    seen: list[tuple[float, float]] = []
    res = sweep(PENDULUM, grid({"l": [0.5, 1.0, 2.0]}), _failing_task, client=client,
                chunk_size=1, progress=lambda d, t: seen.append((d, t)))
    assert list(res.ok) == [False, True, True]
    assert res.failures == [(0, "FloatingPointError: integration diverged")]
    np.testing.assert_array_equal(res.data["twice_l"][1:], [2.0, 4.0])
    assert seen[-1] == (3, 3) and len(seen) == 3


def test_bad_sweeps_are_one_clear_error(tmp_path):
    """Reference: the documented error messages (no cluster is started for them)."""
    with pytest.raises(NeweulError, match="unknown parameter"):
        sweep(PENDULUM, [{"mass": 1.0}], "modes")
    with pytest.raises(NeweulError, match="needs t_end"):
        sweep(PENDULUM, [{"m": 1.0}], "simulate")
    with pytest.raises(NeweulError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9"):
        sweep(PENDULUM, [{"m": 1.0}], "modes", scheduler="tcp://127.0.0.1:9", timeout=0.5)
    with pytest.raises(NeweulError, match="workers must be between 1 and 256"):
        sweep(PENDULUM, [{"m": 1.0}], "modes", workers=100_000)
    with pytest.raises(NeweulError, match="chunk_size must be a whole number ≥ 1"):
        sweep(PENDULUM, [{"m": 1.0}], "modes", chunk_size=0)


def test_cli_sweep_on_a_running_scheduler(client, capsys, tmp_path):
    """Reference: the Python sweep of the same cases."""
    out = tmp_path / "eq.csv"
    code = main(["sweep", str(GENERATED / "double_pendulum.py"), "--param", "m1=1,2",
                 "--task", "equilibrium", "--scheduler", client.scheduler.address,
                 "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0 and "2 ok, 0 failed" in text
    ref = sweep(GENERATED / "double_pendulum.py", [{"m1": 1.0}, {"m1": 2.0}], "equilibrium",
                client=client)
    data = np.genfromtxt(out, names=True, delimiter=",")
    np.testing.assert_allclose(data["phi1"], ref.data["phi1"], atol=1e-12)


def _rogue_client(address: str, **kwargs) -> None:
    """Connect a client to ``address`` on an event loop of its own in this thread (a
    synchronous client that fails to connect leaves its loop thread behind, and the next one
    then waited for its loop in vain: Dask's LoopRunner, "assert loop is not None")."""
    import asyncio

    async def connect_once() -> None:
        client = distributed.Client(address, asynchronous=True, timeout="2s", **kwargs)
        try:
            await client
        finally:
            await client.close()

    asyncio.run(connect_once())


def test_local_cluster_admits_only_its_own_credentials():
    """Reference: Dask's TLS security with temporary credentials
    (``distributed.security.Security.temporary``): the local cluster of a sweep listens on
    ``tls://`` on a free port, without a dashboard; a client without credentials, with other
    temporary credentials or over plain TCP cannot connect (so it cannot submit work); the
    sweep's own client can. A second cluster started meanwhile gets another port."""
    import operator

    from distributed.security import Security

    client, cluster = connect(workers=1, processes=False)
    other = None
    try:
        address = cluster.scheduler_address
        assert address.startswith("tls://127.0.0.1:") and not address.endswith(":8786")
        http = cluster.scheduler.http_server     # no dashboard, a free port, health only
        assert http.address == "127.0.0.1" and http.port != 8787
        assert [r.target.__name__ for r in
                cluster.scheduler.http_application.wildcard_router.rules] == ["HealthHandler"]
        with pytest.raises(TypeError, match="TLS expects"):
            _rogue_client(address)
        with pytest.raises(OSError, match="certificate"):
            _rogue_client(address, security=Security.temporary())
        with pytest.raises(OSError):
            _rogue_client(address.replace("tls://", "tcp://"))
        assert client.submit(operator.add, 1, 2).result() == 3
        other = connect(workers=1, processes=False)
        assert other[1].scheduler_address != address
    finally:
        for c, k in (other or (None, None), (client, cluster)):
            if c is not None:
                c.close()
                k.close()


@pytest.mark.parametrize("target", ["/dev/zero", "fifo", "directory", "latin-1"])
def test_cases_file_is_checked_before_it_is_read(tmp_path, capsys, target):
    """``--cases /dev/zero`` grew to 13.8 GB and ``--cases FIFO`` hung: the file must be a
    regular UTF-8 file of at most 64 MiB (docs/limits.md); one error line, exit 1, no cluster
    started. Reference: POSIX file types."""
    if target == "fifo":
        path = tmp_path / "cases.csv"
        os.mkfifo(path)
    elif target == "directory":
        path = tmp_path
    elif target == "latin-1":
        path = tmp_path / "cases.csv"
        path.write_bytes("m,l\n1,2\n# \u00e9\n".encode("latin-1"))
    else:
        path = Path(target)
    with pytest.raises(DataError):
        read_cases(path)
    code = main(["sweep", str(PENDULUM), "--cases", str(path), "--task", "modes"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and str(path) in err


def test_case_counts_are_capped_before_anything_is_allocated(tmp_path):
    """A grid of 10¹² cases (two ranges of 10⁶ values) or a range of 10¹² values was built in
    memory; the number of cases is capped (docs/limits.md) before any list is made."""
    from neweul_py.analysis.sweep_cases import MAX_CASES, parse_values

    with pytest.raises(NeweulError, match=f"cap of {MAX_CASES}"):
        parse_values("0:1:1000000000000", "m")
    big = np.zeros(1_000_000)
    with pytest.raises(NeweulError, match=f"1000000000000 cases, more than the cap of {MAX_CASES}"):
        grid({"m": big, "l": big})
    with pytest.raises(NeweulError, match="cases, more than the cap"):
        product([{"m": 1.0}] * 1000, [{"l": 1.0}] * 10_000)
    rows = "m\n" + "1\n" * (MAX_CASES + 1)
    (tmp_path / "many.csv").write_text(rows)
    with pytest.raises(DataError, match=f"more than the cap of {MAX_CASES} cases"):
        read_cases(tmp_path / "many.csv")


@pytest.mark.parametrize(("param", "message"), [
    ("m=-1:1:3", r"sweep case 0 \(m = -1\) the mass matrix .* negative mass or inertia"),
    ("l=-1,1", r"sweep case 0 \(l = -1\): l = -1 is outside its range ≥ 0"),
    ("m=1e300", r"m = 1e\+300 is out of range"),
])
def test_cases_are_checked_like_simulate_parameters(capsys, tmp_path, param, message):
    """``sweep --param m=-1:1:3`` ran m = -1 while ``simulate -p m=-1`` refuses it: every case
    goes through the one parameter check of simulate (analysis.admissible) before any
    cluster starts — exit 1, one line naming the case. Reference: the same values given to
    ``neweul simulate -p``, and the pendulum description's range of l."""
    from neweul_py.analysis.admissible import check_parameters

    desc = str(Path(__file__).resolve().parents[2] / "examples" / "pendulum.yaml")
    code = main(["sweep", desc, "--param", param, "--task", "modes"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1
    assert re.search(message, err), err
    name, value = param.split("=")[0], param.split("=")[1].split(":")[0].split(",")[0]
    try:                              # the same value through simulate: refused too
        code = main(["simulate", desc, "--t-end", "0.1", "-p", f"{name}={value}"])
    except SystemExit as exc:         # argparse (exit 2): 1e300 is out of range for -p
        code = exc.code
    err = capsys.readouterr().err
    if value == "1e300":              # argparse's check of -p numbers: a usage error
        assert code == 2 and "m: 1e+300 is out of range" in err
    else:
        assert code == 1 and f"{name} = -1" in err
    mod = load_generated(PENDULUM)
    with pytest.raises(NeweulError):
        check_parameters(mod, np.array([-1.0, 0.5, 9.81]))
