"""Time the symbolic derivation of the N-link planar chain: neweul-py's ``newton_euler`` (and,
when available, code generation with ``neweul_py.codegen.render_module``) versus
``sympy.physics.mechanics.KanesMethod`` derivation alone, in one run, printing ratios.

The chain: N rods, each hinged about z at the end of the previous one (relative angles),
center of mass at half length, rod inertia, gravity −y. Kane's model is the same system with
relative-angle frames, ``v2pt_theory`` velocities and ``u = q̇``.

Usage::

    python benchmarks/bench_derivation.py                 # N = 2 5 10 20 30, Kane for N ≤ 10
    python benchmarks/bench_derivation.py -n 2 5 --kane-max 5 --form recursive
"""

from __future__ import annotations

import argparse
import gc
import time

import sympy as sp
import sympy.physics.mechanics as me

from neweul_py.equations import clear_cache, newton_euler
from neweul_py.model import Coordinate, Frame, Parameter, RigidBody, System, symbol

try:  # code generation is another layer; time it when it is there
    from neweul_py.codegen import render_module
except ImportError:  # pragma: no cover
    render_module = None


def planar_chain(n: int) -> System:
    """The N-link planar chain as a neweul-py model."""
    params = [Parameter("g", 9.81)]
    frames, bodies = [], []
    for i in range(n):
        m, l = symbol(f"m{i}"), symbol(f"l{i}")
        params += [Parameter(f"m{i}", 1.0), Parameter(f"l{i}", 1.0)]
        parent = "ISYS" if i == 0 else f"link{i - 1}"
        origin = [0, 0, 0] if i == 0 else [symbol(f"l{i - 1}"), 0, 0]
        frames.append(Frame(f"link{i}", parent, sp.ImmutableMatrix(origin),
                            (("z", symbol(f"q{i}")),)))
        rod = m * l**2 / 12
        bodies.append(RigidBody(f"rod{i}", f"link{i}", m, sp.ImmutableMatrix([l / 2, 0, 0]),
                                sp.ImmutableMatrix(sp.diag(0, rod, rod))))
    return System(
        f"chain{n}", coordinates=tuple(Coordinate(f"q{i}") for i in range(n)),
        parameters=tuple(params), frames=tuple(frames), bodies=tuple(bodies),
        gravity=sp.ImmutableMatrix([0, -symbol("g"), 0]),
    )


def kane_chain(n: int) -> tuple[sp.Matrix, sp.Matrix]:
    """KanesMethod derivation of the same chain; returns (mass_matrix, forcing)."""
    q = me.dynamicsymbols(f"q0:{n}")
    u = me.dynamicsymbols(f"u0:{n}")
    g = sp.Symbol("g")
    frame_n = me.ReferenceFrame("N")
    joint = me.Point("O")
    joint.set_vel(frame_n, 0)
    parent = frame_n
    bodies, loads = [], []
    for i in range(n):
        m, l = sp.symbols(f"m{i} l{i}")
        f = me.ReferenceFrame(f"L{i}")
        f.orient_axis(parent, parent.z, q[i])
        f.set_ang_vel(parent, u[i] * parent.z)
        com = joint.locatenew(f"G{i}", l / 2 * f.x)
        com.v2pt_theory(joint, frame_n, f)
        rod = m * l**2 / 12
        bodies.append(me.RigidBody(f"B{i}", com, f, m, (me.inertia(f, 0, rod, rod), com)))
        loads.append((com, -m * g * frame_n.y))
        nxt = joint.locatenew(f"J{i}", l * f.x)
        nxt.v2pt_theory(joint, frame_n, f)
        joint, parent = nxt, f
    kd = [qi.diff() - ui for qi, ui in zip(q, u, strict=True)]
    kane = me.KanesMethod(frame_n, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    return kane.mass_matrix, kane.forcing


def size(eq) -> int:
    exprs = [e for _, e in eq.intermediates] + list(eq.mass_matrix) + list(eq.force_vector)
    return int(sp.count_ops(exprs))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, nargs="+", default=[2, 5, 10, 20, 30], help="chain lengths")
    ap.add_argument("--kane-max", type=int, default=10, help="run KanesMethod up to this N")
    ap.add_argument("--form", default="auto", choices=["auto", "closed", "recursive"])
    ap.add_argument("--no-codegen", action="store_true", help="time the derivation only")
    args = ap.parse_args(argv)

    print(f"{'N':>3} {'form':>9} {'derive/s':>9} {'codegen/s':>9} {'ops':>7} "
          f"{'kane/s':>8} {'ratio':>7}")
    for n in args.n:
        system = planar_chain(n)
        clear_cache()
        gc.collect()
        t0 = time.perf_counter()
        eq = newton_euler(system, form=args.form)
        t_derive = time.perf_counter() - t0
        t_gen = float("nan")
        if render_module is not None and not args.no_codegen:
            t0 = time.perf_counter()
            try:
                render_module(eq, system.fingerprint())
                t_gen = time.perf_counter() - t0
            except Exception as exc:  # another layer, possibly mid-change
                print(f"    (codegen failed, timing derivation only: {exc!r:.80})")
        ours = t_derive + (0.0 if t_gen != t_gen else t_gen)
        kane_s, ratio = "-", "-"
        if n <= args.kane_max:
            gc.collect()
            t0 = time.perf_counter()
            kane_chain(n)
            t_kane = time.perf_counter() - t0
            kane_s, ratio = f"{t_kane:8.2f}", f"{t_kane / ours:7.1f}"
        form = "closed" if eq.is_closed_form else "recursive"
        print(f"{n:>3} {form:>9} {t_derive:9.3f} {t_gen:9.3f} {size(eq):7d} {kane_s:>8} "
              f"{ratio:>7}", flush=True)
    print("ratio = KanesMethod derivation / (newton_euler + render_module)")


if __name__ == "__main__":
    main()
