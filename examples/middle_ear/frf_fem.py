"""Umbo velocity per probe pressure of the full (unreduced) FE models of a sweep.

Run after ``build_fem.py`` (see README.md)::

    python examples/middle_ear/frf_fem.py [DIR] [--plot]

For every working point in DIR (default ``data/fem``) the model — with the ossicular support
added back at the manubrium, the chain tangent *of that working point* (file group
``static_chain_tangent``, malleus condensed) so that the TM is held as in the static solution —
is driven by the canal volume-acceleration source with the loss factors (``K + iG``, file group
``loss_G``), and ``|jω u_umbo,z / p_probe|`` [mm/s/Pa] is printed (and plotted to
``DIR/frf_umbo.png`` with ``--plot``). A check of the FE data, not the middle-ear model of the
seed paper (no ossicle masses; ``dp_trend.py`` adds a lumped chain).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import scipy.sparse as sps

from neweul_py.elastic.io.fe_files import read_fe_model
from neweul_py.elastic.io.working_point import read_loss, read_static
from neweul_py.middle_ear.chain import condensed_support
from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.transfer import umbo_transfer

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
    md = me.manubrium_dofs
    rows, cols = np.meshgrid(md, md, indexing="ij")
    curves = {}
    print("umbo velocity / probe pressure [mm/s/Pa]")
    print("  dp [Pa] " + " ".join(f"{f:>7.0f}" for f in FREQS))
    for wp in sweep["working_points"]:
        path = out / wp["file"]
        fe = read_fe_model(path)
        g, _ = read_loss(path)
        ks = condensed_support(
            me.malleus_T, params.k_tm_manubrium, read_static(path)["chain_tangent"]
        )
        sup = sps.csr_matrix(
            (ks.ravel(), (rows.ravel(), cols.ravel())), shape=(me.shell.n_dof,) * 2
        ).tocsr()[me.free_dofs][:, me.free_dofs]
        h = np.abs(umbo_transfer(fe, g, sup, FREQS, params.tm_loss)) * 1e3
        curves[wp["dp_Pa"]] = np.array(h)
        print(f"  {wp['dp_Pa']:+7.0f} " + " ".join(f"{v:7.3f}" for v in h))
    if args.plot:
        from neweul_py.middle_ear.plots import require_matplotlib

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
