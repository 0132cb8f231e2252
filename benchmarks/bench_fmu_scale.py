#!/usr/bin/env python3
"""The middle-ear EMBS as an FMU: export time, size, FMPy's validation, instantiation and the
state derivatives against the generated module, in one run.

Runs ``neweul export`` on ``DATA/middle_ear.yaml`` with the canal source ``Q`` given the
default 0, as a child process (its CPU time from the operating system's accounting,
``_processes.timed_process``), then in this process: the FMU's size and that of its
``resources/`` data before deflation, ``fmpy.validation.validate_fmu``, the model-exchange
instantiation (reading, checking and binding the data) and the state derivatives
``fmi2GetDerivatives`` at the module's start state with every state perturbed, against the
generated module's ``rhs`` at the same state (largest difference relative to the largest
derivative). Nothing is asserted::

    python benchmarks/bench_fmu_scale.py --dir DATA      # after neweul middle-ear build
"""

from __future__ import annotations

import argparse
import ctypes
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
from _processes import timed_process


def _constant_source(data: Path, tmp: Path) -> Path:
    """A copy of ``DATA/middle_ear.yaml`` whose canal source ``Q`` defaults to 0 (an FMU's
    inputs start from a number; the importer drives them) and whose body is named by its
    absolute path."""
    import yaml

    tree = yaml.safe_load((data / "middle_ear.yaml").read_text())
    tree["inputs"]["Q"] = 0
    for body in tree["elastic_bodies"].values():
        body["data"] = str((data / body["data"]).resolve())
    out = tmp / "middle_ear.yaml"
    out.write_text(yaml.safe_dump(tree, sort_keys=False))
    return out


def _derivatives(fmu: Path, unzip: Path, x: np.ndarray, names: list[str]
                 ) -> tuple[np.ndarray, float]:
    """``fmi2GetDerivatives`` at the states ``x`` (named ``names``, the module's order) and
    the seconds of the instantiation."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model

    md = read_model_description(str(fmu))
    extract(str(fmu), unzipdir=str(unzip))
    me = FMU2Model(guid=md.guid, unzipDirectory=str(unzip),
                   modelIdentifier=md.modelExchange.modelIdentifier, instanceName="bench")
    t0 = time.perf_counter()
    me.instantiate()
    seconds = time.perf_counter() - t0
    me.setupExperiment(startTime=0.0)
    me.enterInitializationMode()
    me.exitInitializationMode()
    me.enterContinuousTimeMode()
    order = [d.variable.derivative.name for d in md.derivatives]
    where = [names.index(s) for s in order]
    n = len(order)
    xs = np.ascontiguousarray(x[where], dtype=np.float64)
    dx = np.zeros(n)
    ptr = ctypes.POINTER(ctypes.c_double)
    me.setContinuousStates(xs.ctypes.data_as(ptr), n)
    me.getDerivatives(dx.ctypes.data_as(ptr), n)
    me.terminate()
    me.freeInstance()
    out = np.empty(n)
    out[where] = dx
    return out, seconds


def main() -> None:
    from fmpy.validation import validate_fmu

    from neweul_py.analysis import load_generated

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        desc = _constant_source(args.dir, Path(tmp))
        fmu = Path(tmp) / "middle_ear.fmu"
        cpu, _ = timed_process([sys.executable, "-m", "neweul_py.cli", "export", str(desc),
                                "--fmu", str(fmu), "-q"])
        with zipfile.ZipFile(fmu) as z:
            data = sum(i.file_size for i in z.infolist() if i.filename.startswith("resources/"))
        problems = validate_fmu(str(fmu))
        mod = load_generated(args.dir / "generated" / "middle_ear.py")
        names = [*mod.COORDINATES, *(f"d_{c}" for c in mod.COORDINATES)]
        x = np.asarray(mod.INITIAL_STATE, dtype=float)
        x = x + 1e-9 * np.random.default_rng(1).standard_normal(x.size)
        p = mod.default_parameters()
        ref = mod.rhs(0.0, x, p, mod.default_inputs(0.0, p))
        got, inst = _derivatives(fmu, Path(tmp) / "unzip", x, names)
        print(f"middle-ear FMU: {len(names)} states")
        print("| figure | value |\n|---|---|")
        print(f"| export (child process CPU) | {cpu:.1f} s |")
        print(f"| FMU | {fmu.stat().st_size / 1e6:.1f} MB |")
        print(f"| resources/ before deflation | {data / 1e6:.1f} MB |")
        print(f"| FMPy validation | {'passed' if not problems else '; '.join(problems)} |")
        print(f"| fmi2Instantiate | {inst:.2f} s |")
        err = np.max(np.abs(got - ref)) / np.max(np.abs(ref))
        print(f"| derivatives vs module rhs (relative) | {err:.1e} |")


if __name__ == "__main__":
    main()
