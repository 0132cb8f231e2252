"""Which chain elements should stiffen with Δp? (README.md, "The 3-D chain").

Run from the repository root after ``build_embs.py``::

    python examples/middle_ear/stiffening_variants.py --dir examples/middle_ear/data

For each set of stiffening elements, ``middle_ear.yaml`` with the factor ``φ(Δp)`` on exactly
those elements (stiffness and rotational stiffness; their loss follows through
``loss_factor``), ``φ`` found again so that the chain's static stiffness at the umbo equals the
sweep's tangent (:func:`chain_factor.retarget`), the chain coupled to the unreduced FE model of
each working point (:func:`validate_embs.reference_frf`, viscous equivalent of the losses).
Printed: the mean change 100–1000 Hz re Δp = 0 [dB] of the umbo (TM node 1), the malleus at
the umbo and the stapes, as a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from neweul_py.analysis import load_generated
from neweul_py.api import generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from chain_factor import retarget, with_factor
from studies import low_db
from validate_embs import DESCRIPTION, chain_description, fe_model_at, reference_frf, transfer

VARIANTS = {
    "AML + incudomalleolar joint (used)": ("anterior_mallear_ligament", "incudomalleolar_joint"),
    "AML": ("anterior_mallear_ligament",),
    "AML + PIL": ("anterior_mallear_ligament", "posterior_incudal_ligament"),
    "AML + PIL + annular (all to ground)": ("anterior_mallear_ligament",
                                            "posterior_incudal_ligament", "annular_ligament"),
    "AML + incudomalleolar joint + annular": ("anterior_mallear_ligament",
                                              "incudomalleolar_joint", "annular_ligament"),
}
PRESSURES = (-4000.0, -2000.0, 0.0, 2000.0, 4000.0)
#: A placeholder factor that :func:`chain_factor.retarget` replaces by the table.
PLACEHOLDER = "piecewise(dp < 0, 1.0, 1.0)"


def variant(text: str, elements: tuple[str, ...]) -> str:
    """``text`` with the factor on the stiffnesses of ``elements`` only."""
    d = yaml.safe_load(with_factor(text, "1"))
    for name, e in d["forces"].items():
        for key in ("stiffness", "rotational_stiffness"):
            if key not in e:
                continue
            v = e[key]
            vals = v["diag"] if isinstance(v, dict) else [v]
            vals = [x[:-2] if isinstance(x, str) and x.endswith("*1") else x for x in vals]
            if name in elements:
                vals = [f"{x}*{PLACEHOLDER}" for x in vals]
            e[key] = {"diag": vals} if isinstance(v, dict) else vals[0]
    return yaml.safe_dump(d, sort_keys=False, width=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True)
    ap.add_argument("--gen", type=Path, default=Path("/tmp") / "neweul_variants")
    ap.add_argument("--nf", type=int, default=40)
    args = ap.parse_args()
    f = np.geomspace(100.0, 8000.0, args.nf)
    base = DESCRIPTION.read_text()
    print("| stiffening elements | " + " | ".join(f"{p / 1000:+.0f} kPa" for p in PRESSURES
                                                  if p) + " |")
    print("|---" * (len(PRESSURES)) + "|")
    for label, elements in VARIANTS.items():
        text = retarget(variant(base, elements), args.dir, args.gen)
        path = args.gen / "variant_chain.yaml"
        path.write_text(chain_description(text, args.dir))
        mod = load_generated(generate(path, args.gen))
        H = {}
        for dp in PRESSURES:
            r = reference_frf(mod, fe_model_at(dp, args.dir), dp, f, "viscous")
            H[dp] = transfer(r, f) | {"malleus": r["umbo_velocity_z"] / r["p_probe"]}
        cells = ["/".join(f"{low_db(H[dp][k], H[0.0][k], f):+.1f}"
                          for k in ("umbo", "malleus", "stapes")) for dp in PRESSURES if dp]
        print(f"| {label} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
