#!/usr/bin/env python3
"""Regenerate the shipped examples' modules in ``generated/`` (and the chain and middle-ear
chain descriptions).

Run from anywhere after changing the examples, the equations or the code generator::

    python examples/regenerate.py            # rewrite generated/*.py (and the chain YAMLs)
    python examples/regenerate.py --check    # exit 1 listing what is out of date

``tests/codegen/test_generated_up_to_date.py`` fails while anything here is stale.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
GENERATED = ROOT / "generated"
sys.path.insert(0, str(EXAMPLES))

from make_chain import chain_description  # noqa: E402
from make_middle_ear_chain import description as middle_ear_chain_description  # noqa: E402

#: Description files whose modules are shipped in generated/.
DESCRIPTIONS: tuple[str, ...] = (
    "pendulum.yaml",
    "double_pendulum.yaml",
    "cart_pendulum.yaml",
    "heavy_top.yaml",
    "chain3_spatial.yaml",
    "chain10_planar.yaml",
    # force elements, kinematic loops, kinematic excitation
    "slider_crank.yaml",
    "four_bar.yaml",
    "quarter_car.yaml",
    "middle_ear_chain.yaml",
)
#: Chain descriptions written by make_chain.py: file → (N, spatial).
CHAINS: dict[str, tuple[int, bool]] = {
    "chain3_spatial.yaml": (3, True),
    "chain10_planar.yaml": (10, False),
}


def stale(out_dir: Path | None = None) -> list[str]:
    """Names of the files that differ from a fresh generation (generating into a temp dir)."""
    from neweul_py.api import generate

    bad = [name for name, (n, spatial) in CHAINS.items()
           if (EXAMPLES / name).read_text(encoding="utf-8") != chain_description(n, spatial)]
    if (EXAMPLES / "middle_ear_chain.yaml").read_text(encoding="utf-8") != \
            middle_ear_chain_description():
        bad.append("middle_ear_chain.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        for name in DESCRIPTIONS:
            fresh = generate(EXAMPLES / name, out_dir or tmp)
            shipped = GENERATED / fresh.name
            if not shipped.is_file() or shipped.read_bytes() != fresh.read_bytes():
                bad.append(f"generated/{fresh.name}")
    return bad


def regenerate() -> list[Path]:
    """Rewrite the chain descriptions and every module in generated/."""
    from neweul_py.api import generate
    from neweul_py.atomic import atomic_write

    for name, (n, spatial) in CHAINS.items():
        atomic_write(EXAMPLES / name, chain_description(n, spatial))
    atomic_write(EXAMPLES / "middle_ear_chain.yaml", middle_ear_chain_description())
    return [generate(EXAMPLES / name, GENERATED) for name in DESCRIPTIONS]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only report stale files")
    args = parser.parse_args()
    if args.check:
        bad = stale()
        for b in bad:
            print(f"out of date: {b}")
        return 1 if bad else 0
    for path in regenerate():
        print(path.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
