"""The TM + air body in the loss-factor form against the unreduced FE model (docs/equations.md
§1.1), and how far the viscous equivalent is from it.

Run from the repository root after ``build_embs.py``::

    python examples/middle_ear/check_loss_form.py [--dir examples/middle_ear/data]
        [--pressures 0,-2000]

Per working point: the FE model projected on the body's snapshot basis (the cached
``embs/basis3_*.npz``) solved as ``K_r + iG_r + jω(D_r − G_r/ω_ref) − ω²M_r`` against the
unreduced FE model solved as ``K + iG − ω²M`` (one sparse LU per frequency), canal volume
acceleration → umbo displacement and probe pressure, 25 log frequencies 100 Hz–5 kHz; and the
difference in dB between the FE model's loss-factor and viscous (``D = G/ω_ref``) forms.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from neweul_py.elastic import read_fe_model
from neweul_py.elastic.quality.measures import frf_full, frf_reduced
from neweul_py.elastic.reductors.projection import build_reduced_body

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    ap.add_argument("--pressures", default="0,-2000")
    args = ap.parse_args()
    bases = sorted((args.dir / "embs").glob("basis3_*.npz"))
    if not bases:
        raise SystemExit(f"no snapshot basis in {args.dir / 'embs'}: run build_embs.py first")
    with np.load(bases[0]) as z:
        V = z["V"]
    f = np.geomspace(100.0, 5000.0, 25)
    for dp in (float(v) for v in args.pressures.split(",")):
        fe = read_fe_model(args.dir / "fem" / f"model_dp{int(dp):+06d}.npz")
        if fe.G is None:
            raise SystemExit(f"{fe.source}: no loss group (G) in the FE file")
        body = build_reduced_body(fe, V, V, "snapshot", {})
        for out in ("umbo_uz", "probe_pressure"):
            inp = "canal_volume_acceleration"
            full = frf_full(fe, f, inp, out, method="direct")[:, 0, 0]
            visc = frf_full(fe, f, inp, out, method="direct", damping="viscous")[:, 0, 0]
            err = np.abs(frf_reduced(body, f, inp, out)[:, 0, 0] / full - 1)
            db = 20 * np.log10(np.abs(visc / full))
            k = int(np.argmax(np.abs(db)))
            print(f"dp {dp:+6.0f} Pa {out:15s} order {V.shape[1]} of {fe.n_dofs}: body vs FE "
                  f"(K + iG) max {err.max():.2e}, median {np.median(err):.2e}; viscous form "
                  f"off by up to {db[k]:+.2f} dB (at {f[k]:.0f} Hz)")


if __name__ == "__main__":
    main()
