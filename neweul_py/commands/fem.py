"""``neweul fem middle-ear``: FE models of the TM and the middle-ear air over static pressures;
``neweul fem beam`` / ``neweul fem solid-beam``: beam and solid (Hex8/Hex20/Tet10) cantilever FE
models for ``neweul reduce``."""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path

from ..progress import QUIET_HELP, Tracker
from . import CAPS, count, number, range_type
from . import common as shared

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``fem`` command (sub-command ``middle-ear``)."""
    parser = subparsers.add_parser(
        "fem", help="build acousto-structural FE models (tympanic membrane and middle-ear air)"
    )
    sub = parser.add_subparsers(dest="fem_command", metavar="MODEL", required=True)
    me = sub.add_parser(
        "middle-ear",
        help="TM + ear canal + tympanic cavity, linearized at static pressures",
        description="Solve the nonlinear static TM problem at each static pressure difference "
        "dp = p_canal - p_cavity and write one up-coupled FE model (Eq. (2)) per working "
        "point (the one nearest 0 Pa complete, the others as delta files of it: "
        "docs/fe-file-format.md), the static results (static.csv) and sweep.json into DIR "
        "(atomically). A load step "
        "whose static state leaves the model's validity (TM reaching an air-space wall, cone "
        "inversion, |dV| > 5 % of an air volume) stops the sweep with an error; nothing is "
        "written. Progress goes to stderr.",
    )
    # "--pressures -4000:4000:9" gets through: cli.attach_negative_values
    pressures = range_type("--pressures", increasing=False)
    me.add_argument(
        "--pressures",
        type=pressures,
        default=pressures("-4000:4000:9"),
        metavar="START:STOP:N",
        help="static pressures [Pa]: START:STOP:N or a comma list (default -4000:4000:9, at "
        f"most {CAPS['--pressures']})",
    )
    shared.add_output_argument(me, "DIR", "output directory", required=True)
    me.add_argument("--refine", type=count("--refine", minimum=0), default=2,
                    help=f"mesh refinement level (default 2, at most {CAPS['--refine']})")
    me.add_argument("--plots", action="store_true", help="also write PNG pictures")
    me.add_argument(
        "--include-support",
        action="store_true",
        help="keep the ossicular-chain support springs in the exported stiffness",
    )
    me.add_argument(
        "--static-curve", type=functools.partial(number, option="--static-curve",
                                                 positive=True),
        default=None, metavar="STEP",
        help="also solve the static state every STEP Pa over the sweep's range and write "
        "static_curve.csv (static solves only; the table of an interpolation coordinate: "
        "neweul interpolate --coordinate DIR/static_curve.csv:dp_Pa:volume_displacement_m3)",
    )
    me.add_argument("--parameters", type=Path, default=None, metavar="FILE",
                    help="the middle ear's data that differ from the defaults (a YAML mapping "
                    "of MiddleEarParameters names to numbers, e.g. "
                    "examples/middle_ear/identified.yaml)")
    me.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    me.set_defaults(func=_middle_ear)
    _register_beams(sub)


def _middle_ear(args: argparse.Namespace) -> int:
    from ..middle_ear.parameters import MiddleEarParameters, read_parameters
    from ..middle_ear.sweep import pressure_sweep

    params = MiddleEarParameters(**read_parameters(args.parameters)) if args.parameters \
        else None
    with Tracker("FE sweep", unit="point", quiet=args.quiet) as track:  # a bar on a terminal
        result = pressure_sweep(
            args.pressures.values(),
            params,
            refine=args.refine,
            out_dir=args.output,
            plots=args.plots,
            include_support=args.include_support,
            verbose=True,
            progress=track,
            static_curve=args.static_curve,
        )
    print(f"wrote {len(result.models)} working points to {args.output}")
    return 0


# ------------------------------------------------------------------ beam and solid-beam
def _comma(kind, count: int, what: str):
    def parse(text: str):
        try:
            vals = [kind(x) for x in text.split(",")]
        except ValueError:
            vals = []
        if len(vals) != count:
            raise argparse.ArgumentTypeError(f"expected {count} comma-separated {what}, got "
                                             f"{text!r}")
        return vals
    return parse


def _positive(option: str):
    """A positive finite number (:func:`neweul_py.commands.number`)."""
    return functools.partial(number, option=option, positive=True)


#: Poisson's ratio of an isotropic material: −1 < ν ≤ 0.5.
_POISSON = functools.partial(number, option="--nu", minimum=-1.0, maximum=0.5)


def _register_beams(sub: argparse._SubParsersAction) -> None:
    """Add ``fem beam`` and ``fem solid-beam``."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--stiffening", action="store_true",
                        help="also store the geometric stiffness K_G of the 12 unit inertia "
                        "load cases, root clamped (for `neweul reduce --stiffening`; .npz only)")
    common.add_argument("-o", "--output", required=True, metavar="MODEL.npz",
                        help="FE model file to write (.npz, or a .json manifest)")
    beam = sub.add_parser(
        "beam", parents=[common],
        help="a straight Euler-Bernoulli or Timoshenko beam along x (2-D or 3-D)",
        description="Write the FE model of a uniform straight beam along x (free-free; node "
        "sets root, tip and all in the file). Section from --A/--Iy/--Iz/--Jt or "
        "--rectangle B,H with --nu.")
    beam.add_argument("--length", type=_positive("--length"), default=1.0,
                      help="length (default 1)")
    beam.add_argument("--elements", type=count("--elements", cap=1_000_000), default=20,
                      help="elements (default 20)")
    beam.add_argument("--theory", choices=("euler-bernoulli", "timoshenko"),
                      default="euler-bernoulli")
    beam.add_argument("--planar", action="store_true", help="2-D beam (ux, uy, rz)")
    beam.add_argument("--E", type=_positive("--E"), default=1.0, help="Young's modulus")
    beam.add_argument("--G", type=_positive("--G"), help="shear modulus (default E/(2(1+nu)))")
    beam.add_argument("--nu", type=_POISSON, default=0.3, help="Poisson ratio (default 0.3)")
    beam.add_argument("--rho", type=_positive("--rho"), default=1.0, help="density")
    beam.add_argument("--A", type=_positive("--A"), default=1.0, help="area")
    beam.add_argument("--Iy", type=_positive("--Iy"), default=1e-4, help="second moment about y")
    beam.add_argument("--Iz", type=_positive("--Iz"), default=1e-4, help="second moment about z")
    beam.add_argument("--Jt", type=_positive("--Jt"), help="torsion constant (default Iy + Iz)")
    beam.add_argument("--shear-factor", type=_positive("--shear-factor"), default=5 / 6,
                      help="Timoshenko shear factor (default 5/6)")
    beam.add_argument("--rectangle", type=_comma(float, 2, "numbers"), metavar="B,H",
                      help="solid rectangle width (y) x height (z): sets A, Iy, Iz, Jt, G, "
                      "shear factor")
    beam.add_argument("--rotary", action="store_true", default=None,
                      help="rotary inertia (default: Timoshenko yes, Euler-Bernoulli no)")
    beam.add_argument("--lumped", action="store_true", help="lumped mass matrix")
    beam.set_defaults(func=_beam)
    solid = sub.add_parser(
        "solid-beam", parents=[common],
        help="a box of solid elements (Hex8, Hex20, Tet10) along x",
        description="Write the FE model of a linear-elastic box [0,Lx]x[0,Ly]x[0,Lz] meshed "
        "with solid elements (free; node sets root (x=0 face), tip (x=Lx face), all).")
    solid.add_argument("--size", type=_comma(float, 3, "lengths"), default=[1.0, 0.1, 0.1],
                       metavar="LX,LY,LZ", help="edge lengths (default 1,0.1,0.1)")
    solid.add_argument("--divisions", type=_comma(int, 3, "integers"), default=[10, 1, 1],
                       metavar="NX,NY,NZ", help="cells per direction (default 10,1,1)")
    solid.add_argument("--element", choices=("hex8", "hex20", "tet10"), default="hex20")
    solid.add_argument("--E", type=_positive("--E"), default=1.0, help="Young's modulus")
    solid.add_argument("--nu", type=_POISSON, default=0.3, help="Poisson ratio")
    solid.add_argument("--rho", type=_positive("--rho"), default=1.0, help="density")
    solid.set_defaults(func=_solid_beam)


def _write(model, args: argparse.Namespace) -> int:
    from ..elastic.io.fe_files import write_fe_model

    stiffening = responses = None
    if args.stiffening:
        print("geometric stiffness of the 12 unit inertia load cases (root clamped)",
              file=sys.stderr)
        stiffening = model.stiffening()
        responses = model.stiffening_responses()
    write_fe_model(model.fe, args.output, node_sets=dict(model.node_sets),
                   stiffening=stiffening, stiffening_responses=responses)
    print(f"wrote {args.output}: {model.fe.n_dofs} DOFs, {model.fe.nodes.shape[0]} nodes"
          + (", with stiffening" if stiffening else ""))
    return 0


def _beam(args: argparse.Namespace) -> int:
    from ..errors import NeweulError
    from ..fem.beam import BeamSection, beam_model

    if args.stiffening and not str(args.output).lower().endswith(".npz"):
        raise NeweulError(f"{args.output}: --stiffening writes .npz files only")
    if args.rectangle is not None:
        sec = BeamSection.rectangle(*args.rectangle, E=args.E, nu=args.nu, rho=args.rho)
    else:
        G = args.E / (2 * (1 + args.nu)) if args.G is None else args.G
        sec = BeamSection(E=args.E, G=G, rho=args.rho, A=args.A, Iy=args.Iy, Iz=args.Iz,
                          Jt=args.Jt, shear_factor=args.shear_factor)
    model = beam_model(args.length, args.elements, sec, theory=args.theory,
                       planar=args.planar, rotary=args.rotary, lumped=args.lumped)
    return _write(model, args)


def _solid_beam(args: argparse.Namespace) -> int:
    from ..errors import NeweulError
    from ..fem.solid import SolidMaterial, solid_box

    if args.stiffening and not str(args.output).lower().endswith(".npz"):
        raise NeweulError(f"{args.output}: --stiffening writes .npz files only")
    model = solid_box(args.size, args.divisions,
                      SolidMaterial(E=args.E, nu=args.nu, rho=args.rho), element=args.element)
    return _write(model, args)
