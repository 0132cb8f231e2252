"""Umbo velocity per probe pressure of the full (unreduced) FE models of a sweep.

Run after ``build_fem.py`` (see README.md)::

    python examples/middle_ear/frf_fem.py [DIR] [--plot]

For every working point in DIR (default ``data/fem``) the model — with the ossicular support
added back at the manubrium so that the TM is held as in the static solution — is driven by the
canal volume-acceleration source, and ``|jω u_umbo,z / p_probe|`` [mm/s/Pa] is printed (and
plotted to ``DIR/frf_umbo.png`` with ``--plot``). This is a check of the FE data, not the
middle-ear model of the seed paper (no ossicle masses, linear support).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from neweul_py.elastic.fe_io import read_fe_model
from neweul_py.fem.middle_ear import MiddleEarParameters, build_middle_ear

HERE = Path(__file__).resolve().parent
FREQS = np.array([100, 200, 500, 800, 1000, 1500, 2000, 3000, 4000, 6000], dtype=float)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", nargs="?", default=str(HERE / "data" / "fem"))
    parser.add_argument("--plot", action="store_true")
    args = parser.parse_args()
    out = Path(args.dir)
    sweep = json.loads((out / "sweep.json").read_text())
    params = MiddleEarParameters(**sweep["parameters"])
    me = build_middle_ear(params, sweep["refine"])
    sup = me.support[me.free_dofs][:, me.free_dofs]
    n_p = me.n_p
    w_ref = 2 * np.pi * params.f_ref
    curves = {}
    print("umbo velocity / probe pressure [mm/s/Pa]")
    print("  dp [Pa] " + " ".join(f"{f:>7.0f}" for f in FREQS))
    for wp in sweep["working_points"]:
        fe = read_fe_model(out / wp["file"])
        k = fe.K + sps.block_diag([sup, sps.csr_matrix((n_p, n_p))], format="csr")
        d = fe.D + sps.block_diag(
            [(params.tm_loss / w_ref) * sup, sps.csr_matrix((n_p, n_p))], format="csr"
        )
        b, cp, cu = (
            fe.B("canal_volume_acceleration")[:, 0],
            fe.C("probe_pressure")[0],
            fe.C("umbo_uz")[0],
        )
        h = []
        for f in FREQS:
            w = 2 * np.pi * f
            x = spla.spsolve((k + 1j * w * d - w**2 * fe.M).tocsc(), b.astype(complex))
            h.append(abs(1j * w * (cu @ x) / (cp @ x)) * 1e3)
        curves[wp["dp_Pa"]] = np.array(h)
        print(f"  {wp['dp_Pa']:+7.0f} " + " ".join(f"{v:7.3f}" for v in h))
    if args.plot:
        from neweul_py.fem.plots import require_matplotlib

        plt = require_matplotlib()
        fig, ax = plt.subplots(figsize=(6, 4))
        for dp, h in curves.items():
            ax.loglog(FREQS, h, "o-", ms=3, label=f"{dp:+.0f} Pa")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("|v_umbo / p_probe| [mm/s/Pa]")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "frf_umbo.png", dpi=130)
        print(f"wrote {out / 'frf_umbo.png'}")


if __name__ == "__main__":
    main()
