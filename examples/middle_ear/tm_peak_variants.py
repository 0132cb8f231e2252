"""What moves the stapes peaks at Δp = 0, the chain's and the TM's own mode? (README.md,
"Studies", the Δp = 0 reading).

Run from the repository root after ``build_embs.py``::

    python examples/middle_ear/tm_peak_variants.py --dir DATA \\
        --tm tm_loss=0.13 --tm tm_depth=1.5e-3 --chain k_tm_node=x0.3 --chain k_tm_node=x10

At Δp = 0 the chain of the build (``middle_ear.yaml`` without the TM body,
:func:`validate_embs.chain_description`) is coupled to the *unreduced* FE model
(:func:`validate_embs.reference_frf`, loss factors as ``K + iG``), so that no reduction error
enters. ``--tm NAME=VALUE[,NAME=VALUE]`` rebuilds the FE model of Δp = 0 with other
:class:`~neweul_py.middle_ear.parameters.MiddleEarParameters` (same refinement; a parameter that
moves
the manubrium nodes off the build's, such as ``manubrium_reach``, is refused by the chain
coupling); ``--chain NAME=VALUE`` or ``NAME=xFACTOR`` changes a parameter of the chain module
(``k_tm_node``, the ligaments, …). Printed per variant: the stapes velocity per probe pressure
at 1 kHz, every local maximum ``|v_s/p| @ f`` [mm/s/Pa @ Hz] and the largest umbo (TM node)
velocity, on ``--nf`` log-spaced frequencies in ``--band``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from neweul_py.commands import number as cli_number
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sweep import pressure_sweep

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_embs import (
    model_path,
    modules,
    parameters_at,
    reference_frf,
    require_build,
    transfer,
)


def assignments(text: str) -> dict[str, str]:
    """``a=1,b=x2`` → ``{"a": "1", "b": "x2"}`` (values parsed by the caller, never evaluated)."""
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise SystemExit(f"{text!r}: expected NAME=VALUE[,NAME=VALUE]")
        out[name.strip()] = value.strip()
    return out


def number(value: str, default: float, where: str) -> float:
    """``"1.5e-3"`` or ``"x0.3"`` (a factor on ``default``), each as the CLI's
    :func:`neweul_py.commands.number` (finite, bounded)."""
    try:
        if value.startswith("x"):
            return cli_number(value[1:], where) * default
        return cli_number(value, where)
    except argparse.ArgumentTypeError as exc:
        raise SystemExit(str(exc)) from None


def summary(f: np.ndarray, h: dict[str, np.ndarray]) -> str:
    """Stapes at 1 kHz, its local maxima, the largest umbo velocity [mm/s/Pa]."""
    s, u = np.abs(h["stapes"]) * 1e3, np.abs(h["umbo"]) * 1e3
    peaks = [i for i in range(1, len(f) - 1) if s[i - 1] < s[i] >= s[i + 1]]
    k1 = int(np.argmin(np.abs(f - 1000.0)))
    return (f"stapes {s[k1]:.3f} at {f[k1]:.0f} Hz; peaks "
            + ", ".join(f"{s[i]:.3f} @ {f[i]:.0f}" for i in peaks)
            + f"; umbo max {u.max():.3f} @ {f[int(u.argmax())]:.0f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of build_embs.py")
    ap.add_argument("--tm", action="append", default=[], help="FE parameters, NAME=VALUE,…")
    ap.add_argument("--chain", action="append", default=[], help="chain parameters, NAME=VALUE")
    ap.add_argument("--nf", type=int, default=60)
    ap.add_argument("--band", default="500,5000", help="FMIN,FMAX [Hz]")
    args = ap.parse_args()
    require_build(args.dir, 0.0)
    lo, hi = (float(v) for v in args.band.split(","))
    f = np.geomspace(lo, hi, args.nf)
    sweep = json.loads((args.dir / "fem" / "sweep.json").read_text())
    base = MiddleEarParameters(**sweep["parameters"])
    _, chain = modules(args.dir)
    names, p0 = list(chain.PARAMETERS), parameters_at(chain, 0.0)

    def run(label: str, fe_path: Path, p: np.ndarray) -> None:
        print(f"{label}: " + summary(f, transfer(reference_frf(chain, fe_path, 0.0, f, p=p), f)),
              flush=True)

    run("build", model_path(args.dir / "fem", 0.0), p0)
    for text in args.chain:
        p = p0.copy()
        for name, value in assignments(text).items():
            if name not in names:
                raise SystemExit(f"--chain {text}: the chain has no parameter {name!r}")
            p[names.index(name)] = number(value, p0[names.index(name)], f"--chain {name}")
        run(f"chain {text}", model_path(args.dir / "fem", 0.0), p)
    for text in args.tm:
        kw = {}
        for name, value in assignments(text).items():
            if not hasattr(base, name):
                raise SystemExit(f"--tm {text}: MiddleEarParameters has no field {name!r}")
            kw[name] = number(value, getattr(base, name), f"--tm {name}")
        with tempfile.TemporaryDirectory() as tmp:
            pressure_sweep([0.0], replace(base, **kw), sweep["refine"], out_dir=tmp)
            run(f"tm {text}", model_path(Path(tmp), 0.0), p0)


if __name__ == "__main__":
    main()
