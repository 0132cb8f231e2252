#!/usr/bin/env python3
"""Elastic bodies in generated modules: cost as the number of modes grows.

Model: a rigid double pendulum (two links, planar hinges about z, gravity) carrying on its second
link an elastic cantilever (``tests/support/beam_fe.py``, 3-D Euler–Bernoulli, 40 elements,
clamped modes, invariants with centrifugal stiffening) with ``nq`` = 10, 50, 200 modes and one
node frame at the tip, where a spring–damper ties it to the ground. The rigid part alone is the
same description without the elastic body (the tip spring then acts on the link).

Measured in one run, per ``nq``: generation time (``load → newton_euler → render → write``),
module size, and the time per call of ``rhs`` (CPU time, all modules timed interleaved in
rounds, the best of each: :func:`_time_all`), NumPy module and compiled module
(``backend="c"``: the kernel traced into C, the body data bound from the data file);
printed with the ratio to the rigid part
alone (after one warm-up generation), and the number of NumPy-level operations one
NumPy ``rhs`` call executes in the embedded kernel (the ``ffrf_*`` functions: array operators
and stores into arrays, counted bytecode by bytecode, plus calls of NumPy functions and array
methods; slicing and look-ups are not counted; each operation costs roughly 0.3–1 µs).
Nothing is asserted.

BLAS runs single-threaded (``OPENBLAS_NUM_THREADS`` etc. default to 1 here, set before NumPy is
imported): for these small matrices threads only add overhead, and on a loaded machine the
threaded ``numpy.linalg.solve`` of a 200×200 system was 400× slower (0.14 s instead of 0.3 ms).

Usage::

    python benchmarks/bench_elastic.py            # nq = 10, 50, 200
    python benchmarks/bench_elastic.py 10 20      # other mode counts
"""

from __future__ import annotations

import dis
import os
import sys
import tempfile
import time
import timeit
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "support"))

from beam_fe import DOUBLE_PENDULUM as RIGID  # noqa: E402
from beam_fe import beam  # noqa: E402

from neweul_py.analysis import load_generated  # noqa: E402
from neweul_py.api import generate  # noqa: E402
from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening  # noqa: E402

ELASTIC = """
elastic_bodies:
  beam: {{frame: link2, data: {data}, nodes: {{tip: {tip_id}}}}}
"""


def _time_all(mods: dict[str, object], rounds: int = 25) -> dict[str, float]:
    """The best CPU time per ``rhs`` call of each module, measured interleaved: ``rounds``
    rounds, in each a best of 3 loops of ~0.01 s per module, the minimum over the rounds
    (``time.process_time``: on the shared machine wall-clock loops also count the other
    jobs; interleaving lets a change of the machine's load reach every module alike instead
    of the one that happens to be timed then)."""
    calls = {}
    for key, mod in mods.items():
        p = mod.default_parameters()
        x = np.array(mod.INITIAL_STATE, dtype=float)
        x[len(mod.COORDINATES):] = 0.1
        calls[key] = (lambda mod=mod, x=x, p=p: mod.rhs(0.0, x, p))
    numbers = {}
    for key, call in calls.items():
        single = timeit.Timer(call, timer=time.process_time).timeit(20) / 20
        numbers[key] = max(20, int(0.01 / max(single, 1e-7)))
    best = dict.fromkeys(calls, float("inf"))
    for _ in range(rounds):
        for key, call in calls.items():
            runs = timeit.Timer(call, timer=time.process_time).repeat(3, numbers[key])
            best[key] = min(best[key], min(runs) / numbers[key])
    return best


#: Bytecodes of the kernel counted as one NumPy-level operation each (array arithmetic and
#: products, stores into arrays; the few integer sums of indices are counted too).
_OPS = {dis.opmap["BINARY_OP"], dis.opmap["STORE_SUBSCR"]}


def _is_numpy(fn) -> bool:
    """Whether a C function (``c_call``) is NumPy's: a NumPy function or an array method."""
    owner = getattr(fn, "__self__", None)
    return (str(getattr(fn, "__module__", None) or "").startswith("numpy")
            or isinstance(owner, np.ndarray) or owner is np)


def _kernel_ops(mod) -> int:
    """NumPy-level operations of one ``rhs`` call in the embedded kernel (``ffrf_*``
    functions): the bytecodes ``_OPS`` (``sys.settrace``) plus the calls of NumPy functions
    and array methods made from it (``sys.setprofile``), each outermost call counted once."""
    p = mod.default_parameters()
    x = np.array(mod.INITIAL_STATE, dtype=float)
    x[len(mod.COORDINATES):] = 0.1
    count = 0

    def kernel(frame) -> bool:
        return frame is not None and frame.f_code.co_name.startswith("ffrf_")

    def trace(frame, event, _arg):
        nonlocal count
        if not kernel(frame):
            return None
        frame.f_trace_opcodes = True
        if event == "opcode" and frame.f_code.co_code[frame.f_lasti] in _OPS:
            count += 1
        return trace

    def profile(frame, event, arg):
        nonlocal count
        if event == "c_call" and kernel(frame) and _is_numpy(arg):
            count += 1
        elif (event == "call" and kernel(frame.f_back)
              and str(frame.f_globals.get("__name__", "")).startswith("numpy.")
              and not frame.f_code.co_name.endswith("_dispatcher")):
            # NumPy's Python-level functions (by module: the generated module's own functions
            # sit in a directory gen_numpy; array-function dispatchers: not a second call)
            count += 1

    mod.rhs(0.0, x, p)                        # a warm call (lazy set-up is not counted)
    sys.settrace(trace)
    sys.setprofile(profile)
    try:
        mod.rhs(0.0, x, p)
    finally:
        sys.setprofile(None)
        sys.settrace(None)
    return count


def _generate(text: str, directory: Path, name: str,
              backend: str = "numpy") -> tuple[float, object, int, int]:
    """Generation time, the loaded module (``None`` when the backend fell back), its size
    and the kernel operations of its ``rhs`` (NumPy)."""
    desc = directory / f"{name}.yaml"
    desc.write_text(text)
    t0 = time.perf_counter()
    path = generate(desc, directory / f"gen_{backend}", backend=backend)
    gen = time.perf_counter() - t0
    mod = load_generated(path)
    if getattr(mod, "BACKEND", "numpy") != backend:
        return gen, None, path.stat().st_size, 0
    ops = _kernel_ops(mod) if backend == "numpy" else 0
    return gen, mod, path.stat().st_size, ops


def main(counts: list[int]) -> None:
    b = beam(40, length=1.0, E=2.0e5)
    _lam, V = b.clamped_modes(max(counts))
    kg = stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                           support=np.arange(6), cases=("wxx", "wyy", "wzz"))
    tip_id = int(b.fe.nodes[-1, 0])
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _generate(RIGID.format(name="warmup", extra="", tip="link2"), d, "warmup")
        g0, m0, s0, _o = _generate(RIGID.format(name="rigid", extra="", tip="link2"), d,
                                   "rigid")
        _gc, mc, _sc, _o = _generate(RIGID.format(name="rigidc", extra="", tip="link2"), d,
                                     "rigidc", "c")
        mods = {"rigid": m0, "rigid C": mc}
        rows = []
        for nq in counts:
            t0 = time.perf_counter()
            inv = compute_invariants(b.fe, V[:, :nq], nodes=[tip_id], geometric_stiffness=kg)
            t_inv = time.perf_counter() - t0
            np.savez(d / f"beam{nq}.npz", **inv.to_flat())
            extra = ELASTIC.format(data=f"beam{nq}.npz", tip_id=tip_id)
            g, mods[nq], s, ops = _generate(RIGID.format(name=f"flex{nq}", extra=extra,
                                                         tip="beam.tip"), d, f"flex{nq}")
            text = RIGID.format(name=f"flex{nq}c", extra=extra, tip="beam.tip")
            gc, mods[f"{nq} C"], _s, _o = _generate(text, d, f"flex{nq}c", "c")
            rows.append((nq, g, t_inv, s, ops, gc))
        best = _time_all({k: m for k, m in mods.items() if m is not None})
        r0, rc = best["rigid"], best.get("rigid C", float("nan"))
        print(f"rigid part alone: generate {g0:.2f} s, rhs {r0 * 1e6:.1f} µs/call (C: "
              f"{rc * 1e6:.2f} µs), module {s0 / 1e3:.0f} kB")
        print("| modes | generate | rhs per call | rhs / rigid | kernel ops | module size | "
              "C rhs | C / rigid C |")
        print("|---|---|---|---|---|---|---|---|")
        print(f"| rigid only | {g0:.2f} s | {r0 * 1e6:.1f} µs | 1 | 0 | {s0 / 1e3:.0f} kB | "
              f"{rc * 1e6:.2f} µs | 1 |")
        for nq, g, t_inv, s, ops, gc in rows:
            r = best[nq]
            rcq = best.get(f"{nq} C", float("nan"))
            c_cols = f"{rcq * 1e6:.2f} µs (+ {gc:.1f} s) | {rcq / rc:.2f}×"
            print(f"| {nq} | {g:.2f} s (+ invariants {t_inv:.2f} s) | {r * 1e6:.1f} µs | "
                  f"{r / r0:.1f}× | {ops} | {s / 1e3:.0f} kB | {c_cols} |")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [10, 50, 200])
