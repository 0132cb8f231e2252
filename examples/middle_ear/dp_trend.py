"""Low-frequency transmission vs static pressure: the measured-ear check of the FE data.

Run from the repository root (see README.md)::

    python examples/middle_ear/dp_trend.py [--refine 0] [--pressures -4000:4000:9]

For each Δp: the static umbo displacement and TM volume displacement, and the change in dB
(mean over 100–1000 Hz, relative to Δp = 0) of the umbo velocity per probe pressure — (a) with
the chain *support* linearized at the working point (malleus condensed) and (b) with the
LVATB1-like lumped chain (masses, cochlear load) assembled directly, which also gives the
stapes. Δp = p_canal − p_cavity: Δp > 0 is a negative middle-ear pressure. Compare with
Gyo & Goode 1987 (docs/middle-ear-measurements.md).
"""

from __future__ import annotations

import argparse

import numpy as np

from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.static import solve_static, static_summary, support_at
from neweul_py.middle_ear.sweep import parse_pressures
from neweul_py.middle_ear.transfer import chain_transfer, umbo_transfer
from neweul_py.middle_ear.working_point import hysteretic_damping, static_data, working_point_model

LOW = np.geomspace(100.0, 1000.0, 7)


def trend(params: MiddleEarParameters, refine: int, pressures, freqs=LOW):
    """Rows (dp, umbo_uz, dV, dB umbo (support), dB umbo (chain), dB stapes (chain), |H| 1 kHz)."""
    me = build_middle_ear(params, refine)
    states = solve_static(me, pressures)
    fi = me.free_dofs
    out = {}
    for s in states:
        fe = working_point_model(me, s)
        g = hysteretic_damping(me, s)
        sup = support_at(me, s).tocsr()[fi][:, fi]
        hu = umbo_transfer(fe, g, sup, freqs, support_loss=params.tm_loss)
        ch = chain_transfer(fe, g, static_data(me, s), me.malleus_T, params.k_tm_manubrium, freqs)
        out[s.load] = (static_summary(me, s), hu, ch["umbo"], ch["stapes"])
    ref = out[min(out, key=abs)]
    rows = []
    for dp in sorted(out):
        row, hu, cu, cs = out[dp]

        def db(h, h0):
            return float(np.mean(20 * np.log10(np.abs(h) / np.abs(h0))))

        rows.append((dp, row["umbo_uz_m"], row["volume_displacement_m3"], db(hu, ref[1]),
                     db(cu, ref[2]), db(cs, ref[3]), abs(cu[-1]), abs(cs[-1])))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refine", type=int, default=0)
    parser.add_argument("--pressures", default="-4000:4000:9")
    args = parser.parse_args()
    rows = trend(MiddleEarParameters(), args.refine, parse_pressures(args.pressures))
    print("dp[Pa]  umbo_uz[um]  dV[mm3]  dB_umbo(support)  dB_umbo(chain)  dB_stapes(chain)"
          "  |v_u/p|@1k[mm/s/Pa]  |v_s/p|@1k")
    for dp, uz, dv, a, b, c, hu, hs in rows:
        print(f"{dp:+7.0f} {uz * 1e6:+10.1f} {dv * 1e9:+8.3f} {a:+12.2f} {b:+15.2f} {c:+15.2f}"
              f" {hu * 1e3:14.4f} {hs * 1e3:12.4f}")


if __name__ == "__main__":
    main()
