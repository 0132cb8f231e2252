"""Long fuzzing run of every reader (the default test suite runs a bounded sample of the same).

Mutated descriptions (loaded; a share also derived, generated, imported and evaluated: ``rhs``,
``outputs``, ``rhs_jacobian``), reduced-body files, FE models (``.npz`` and Matrix Market), SID
files, tables (sweep cases, CSV results of any tool) and result files read back, with the
mutators of tests/support/fuzz_inputs.py; then SIGKILLs at random moments of an atomic directory
write. Prints, per kind, how many cases ran, how many gave a result, a NeweulError, another
exception (a bug) or a hang (no answer within ``--hang`` s), and the directory states after the
kills.

There is no peer to compare with: the figure is the count of exceptions outside the error
hierarchy (goal 0 in ≥ 10 000 cases).

Usage::

    python benchmarks/bench_fuzz.py [--descriptions 6000] [--generate 600] [--data 4000]
                                     [--tables 2000] [--kills 20] [--seed 0]
"""

from __future__ import annotations

import argparse
import collections
import functools
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tests" / "support")]

import fuzz_inputs as fz  # noqa: E402
import numpy as np  # noqa: E402
from fe_builders import piston_duct  # noqa: E402

from neweul_py.errors import NeweulError  # noqa: E402


class Hang(Exception):
    """No answer within the hang limit."""


def _alarm(*_):
    raise Hang


class Tally:
    def __init__(self, hang: float) -> None:
        self.hang = hang
        self.counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
        self.bugs: dict[str, list[str]] = collections.defaultdict(list)

    def run(self, kind: str, call) -> None:
        signal.setitimer(signal.ITIMER_REAL, self.hang)
        try:
            call()
            self.counts[kind]["result"] += 1
        except Hang:
            self.counts[kind]["hang"] += 1
        except NeweulError as exc:
            one_line = "\n" not in str(exc).strip()
            self.counts[kind]["error" if one_line else "multi-line error"] += 1
        except Exception as exc:  # exactly what the fuzzing looks for
            self.counts[kind]["other exception"] += 1
            tb = traceback.extract_tb(exc.__traceback__)[-1]
            self.bugs[kind].append(f"{type(exc).__name__} at {Path(tb.filename).name}:"
                                   f"{tb.lineno}: {str(exc)[:100]}")
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)

    def report(self) -> int:
        total = bad = 0
        print(f"{'kind':<28}{'cases':>8}{'result':>9}{'error':>9}{'other':>8}{'hang':>6}")
        for kind, c in self.counts.items():
            n = sum(c.values())
            total += n
            other = c["other exception"] + c["multi-line error"]
            bad += other + c["hang"]
            print(f"{kind:<28}{n:>8}{c['result']:>9}{c['error']:>9}{other:>8}{c['hang']:>6}")
        print(f"{'total':<28}{total:>8}   exceptions outside the hierarchy or hangs: {bad}")
        for kind, bugs in self.bugs.items():
            for line in collections.Counter(bugs).most_common(10):
                print(f"  {kind}: {line[1]}× {line[0]}")
        return bad


def descriptions(tally: Tally, n_load: int, n_generate: int, rng: random.Random) -> None:
    from neweul_py.description import load_description_text

    trees = fz.seed_trees()
    names = sorted(trees)
    for i in range(n_load + n_generate):
        name = rng.choice(names)
        plausible = i >= n_load or rng.random() < 0.3  # mostly valid: reach codegen
        try:
            text = fz.dump(fz.mutate_tree(trees[name], rng, plausible=plausible))
        except (RecursionError, ValueError):
            continue
        if i < n_load:
            tally.run("description (load)",
                      functools.partial(load_description_text, text, f"{name}.yaml"))
        else:
            tally.run("description (generate)", functools.partial(_generate, text, name))


def _generate(text: str, name: str) -> None:
    from neweul_py.analysis.module import check_protocol
    from neweul_py.cache import import_verified
    from neweul_py.codegen import render_module
    from neweul_py.description import load_description_text
    from neweul_py.equations import newton_euler

    system = load_description_text(text, f"{name}.yaml")
    if not system.coordinates:
        return
    module = import_verified(f"/fuzz/{name}.py",
                             render_module(newton_euler(system), "0" * 64).encode())
    check_protocol(module)
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    p = module.default_parameters()
    u = module.default_inputs(0.0, p)
    with np.errstate(all="ignore"):
        for evaluate in (module.rhs, module.outputs, module.rhs_jacobian):
            try:
                evaluate(0.0, x0, p, u)
            except (ArithmeticError, np.linalg.LinAlgError):
                pass  # the analysis layer reports these as SolverError


def data_files(tally: Tally, n: int, rng: random.Random, work: Path) -> None:
    from neweul_py.elastic import read_fe_model, reduce_modal, write_fe_model
    from neweul_py.elastic.io.body_files import load_reduced_body, save_reduced_body
    from neweul_py.elastic.io.reader import read_elastic_data

    fe = piston_duct(12, damping=1.0)
    save_reduced_body(reduce_modal(fe, modes=4, store_bases=True).with_(
        parameters={"t": 1.0}, invariants={"m": np.array(1.5)}), work / "body.npz")
    write_fe_model(fe, work / "fe.npz")
    write_fe_model(fe, work / "fe.json")
    body, fenpz = dict(np.load(work / "body.npz")), dict(np.load(work / "fe.npz"))
    manifest = json.loads((work / "fe.json").read_text())
    mtx = {k: (work / v).read_text() for k, v in manifest["matrices"].items()}
    sid = (ROOT / "tests" / "data" / "beam.SID_FEM").read_text().splitlines()
    for i in range(n):
        kind = i % 4
        if kind == 0:
            np.savez(work / "m.npz", **fz.mutate_npz(body, rng))
            tally.run("reduced body", lambda: load_reduced_body(work / "m.npz"))
        elif kind == 1:
            np.savez(work / "f.npz", **fz.mutate_npz(fenpz, rng))
            tally.run("FE model (.npz)", lambda: read_fe_model(work / "f.npz"))
        elif kind == 2:
            key = rng.choice(sorted(mtx))
            target = work / manifest["matrices"][key]
            target.write_text("\n".join(fz.mutate_lines(mtx[key].splitlines(), rng)) + "\n")
            tally.run("FE model (.mtx)", lambda: read_fe_model(work / "fe.json"))
            target.write_text(mtx[key])
        else:
            (work / "b.SID_FEM").write_text("\n".join(fz.mutate_lines(sid, rng)) + "\n")
            tally.run("SID file", lambda: read_elastic_data(work / "b.SID_FEM"))


def tables(tally: Tally, n: int, rng: random.Random, work: Path) -> None:
    """Mutated tables (sweep cases, the CSV and .npz results compare reads) and result files
    read back (simulation results, modes, frequency responses, linear models, sweep tables):
    the readers of tests/analysis/test_results_fuzz.py."""
    from neweul_py.analysis import frequency_response, linearize, load_generated, modes
    from neweul_py.analysis.compare_io import read_table
    from neweul_py.analysis.frf import FrequencyResponse
    from neweul_py.analysis.linearize import LinearModel
    from neweul_py.analysis.modes import ModalResult
    from neweul_py.analysis.results import load_npz
    from neweul_py.analysis.simulate import simulate
    from neweul_py.analysis.sweep_cases import read_cases

    module = load_generated(ROOT / "generated" / "quarter_car.py")
    res, lin = simulate(module, 0.2, n_out=21), linearize(module)
    (work / "cases.csv").write_text("ms,ks\n# mass and stiffness\n250,16000\n300,18000\n")
    csv = {"cases": (work / "cases.csv", read_cases),
           "compare table": (res.save(work / "result.csv"), read_table)}
    npz = {"results": (res.save(work / "result.npz"), load_npz),
           "modes": (modes(lin).save(work / "modes.npz"), ModalResult.load),
           "frf": (frequency_response(lin, [1.0, 2.0]).save(work / "frf.npz"),
                   FrequencyResponse.load),
           "linear model": (lin.save(work / "lin.npz"), LinearModel.load)}
    for i in range(n):
        if i % 2:
            kind = rng.choice(sorted(csv))
            path, reader = csv[kind]
            raw = path.read_bytes()
            data = (fz.mutate_bytes(raw, rng) if rng.random() < 0.5 else
                    "\n".join(fz.mutate_lines(raw.decode().splitlines(), rng)).encode())
            (work / "t.csv").write_bytes(data)
            tally.run(f"table ({kind})", functools.partial(reader, work / "t.csv"))
        else:
            kind = rng.choice(sorted(npz))
            path, reader = npz[kind]
            with np.load(path) as f:
                arrays = {k: f[k] for k in f.files}
            np.savez(work / "t.npz", **fz.mutate_npz(arrays, rng, meta_key="__none__"))
            tally.run(f"result file ({kind})", functools.partial(reader, work / "t.npz"))


_WRITER = """
import sys, time
from neweul_py.middle_ear.output import write_directory_atomically
def fill(tmp):
    for k in range(40):
        (tmp / f"part{k}.bin").write_bytes(b"x" * 200_000)
    return {"tag": sys.argv[2]}
write_directory_atomically(sys.argv[1], fill)
"""


def kills(n: int, rng: random.Random, work: Path) -> collections.Counter:
    """SIGKILL a directory writer at random moments; the final name must hold the old or the
    complete new output, and the next run must leave no temporaries."""
    out = work / "sweep"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", _WRITER, str(out), "old"], env=env, check=True)
    duration = time.perf_counter() - t0
    states: collections.Counter = collections.Counter()
    for _ in range(n):
        proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(out), "new"], env=env)
        time.sleep(rng.uniform(0.3, 1.2) * duration)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        try:
            tag = json.loads((out / "sweep.json").read_text())["tag"]
            complete = len(list(out.glob("part*.bin"))) == 40
            states[f"{tag}{'' if complete else ' (incomplete!)'}"] += 1
        except (OSError, ValueError):
            states["missing!"] += 1
        subprocess.run([sys.executable, "-c", _WRITER, str(out), "old"], env=env, check=True)
        leftovers = [p.name for p in work.iterdir() if p.name.startswith(".sweep.")]
        if leftovers:
            states["leftovers after the next run!"] += 1
    return states


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--descriptions", type=int, default=6000)
    ap.add_argument("--generate", type=int, default=600)
    ap.add_argument("--data", type=int, default=4000)
    ap.add_argument("--tables", type=int, default=2000)
    ap.add_argument("--kills", type=int, default=20)
    ap.add_argument("--hang", type=float, default=10.0, help="seconds until a case hangs")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    signal.signal(signal.SIGALRM, _alarm)
    rng = random.Random(args.seed)
    tally = Tally(args.hang)
    work = Path(tempfile.mkdtemp(prefix="neweul-fuzz-"))
    t0 = time.perf_counter()
    try:
        descriptions(tally, args.descriptions, args.generate, rng)
        data_files(tally, args.data, rng, work)
        tables(tally, args.tables, rng, work)
        bad = tally.report()
        print(f"{time.perf_counter() - t0:.0f} s")
        if args.kills:
            states = kills(args.kills, rng, work)
            print(f"SIGKILL of `write_directory_atomically` at random moments ({args.kills}×): "
                  f"{dict(states)}")
            bad += sum(v for k, v in states.items() if "!" in k)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
