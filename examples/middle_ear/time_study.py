"""Time study of the middle-ear EMBS: a tone under a slow Δp ramp.

Run from the repository root after ``neweul middle-ear build --dir DATA``::

    python examples/middle_ear/time_study.py --dir DATA [--out DIR] [--t-ramp 0.35]
        [--dp-peak 2000] [--f-tone 1000] [--steps-per-period 100] [--backend c|numpy]
        [--check-only]

A tone ``Q = Q_amp sin(2π f t)`` in the canal while the static pressure difference goes
``Δp(t) = dp + dp_ramp sin²(π t / t_ramp)``: 0 → +2000 Pa → 0 in 350 ms (a middle-ear pressure
of −2 kPa and back, swallow-like). The module is generated from a copy of the build's
``middle_ear.yaml`` in which every ``dp`` — the body's schedule and the chain's ligament
factor φ(dp) — is ``Δp(t)``; ``dp_ramp = 0`` gives the frozen module at ``dp``.

Frozen-parameter equations (docs/equations-middle-ear.md §7): the body is the interpolated
``X(σ(t))``; the time derivatives of the weights (``Ẋ = X′ σ̇``) and the motion of the static
state are not taken. The README states how slow the ramp is against the tone and the TM.

Steps:

1. generation, compiled by default (``--backend numpy``: the NumPy module; cached by content:
   a second run skips it);
2. **check** at constant Δp (``dp_ramp = 0``): from the steady state of the linearized module
   at ``t = 0`` (``x₀`` from the FRF), ``--check-periods`` periods; the amplitude of the last
   period (lock-in at the tone) of the umbo velocity and the probe pressure against
   ``|H(f)| |Q|`` of :func:`neweul_py.analysis.frf` of the same module (the viscous ``D`` of
   the time-domain module on both sides);
3. the **ramp**: from the steady state at Δp = 0, generalized-α (Chung & Hulbert 1993, ρ∞ =
   ``--rho-inf``) with the step ``h = 1/(f · steps_per_period)``; the tone amplitude per
   period against the quasi-static envelope ``|H(f; Δp(t))| |Q|`` from FRFs at 21 Δp.

Writes ``time_traces.csv`` (t, Δp, outputs), ``time_envelope.csv`` (per period: t, Δp, the
simulated and the quasi-static amplitudes) and ``time_results.md`` into ``--out``, and
``embs_ramp.png`` (``--plot``, default next to this script).
"""

from __future__ import annotations

import argparse
import csv
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from neweul_py.analysis import frf, load_generated, simulate
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate
from neweul_py.middle_ear.study import build_record
from neweul_py.progress import Tracker

#: The swallow-like bump 0 → 1 → 0 over 0 ≤ t ≤ t_ramp (no piecewise(): the chain factor
#: compares dp in its own piecewise(), and comparisons may not contain one).
RAMP = "sin(pi*t/t_ramp)**2"
#: The outputs of the study: umbo (malleus at the umbo) and stapes velocity, probe pressure.
OUTPUTS = ("umbo_velocity_z", "stapes_velocity", "p_probe")


def ramp_description(data: Path) -> str:
    """The build's ``middle_ear.yaml`` (its body named by absolute path) with every ``dp``
    below ``coordinates:`` replaced by ``dp + dp_ramp*sin²(πt/t_ramp)`` and the parameters
    ``dp_ramp`` [Pa] and ``t_ramp`` [s] added."""
    text = (data / "middle_ear.yaml").read_text()
    body = yaml.safe_load(text)["elastic_bodies"]["tm"]["data"]
    text = text.replace(f"data: {body}", f"data: {(data / body).resolve()}", 1)
    head, body = text.split("\ncoordinates:", 1)
    body = re.sub(r"\bdp\b", f"(dp + dp_ramp*{RAMP})", body)
    if "\nparameters:\n" not in head:
        raise SystemExit("middle_ear.yaml: no parameters block before coordinates")
    head = head.replace("\nparameters:\n", "\nparameters:\n  dp_ramp: 0.0\n  t_ramp: 0.35\n", 1)
    head = re.sub(r"^name: .*$", "name: middle_ear_ramp", head, count=1, flags=re.M)
    return head + "\ncoordinates:" + body


def ramp_module(data: Path, out: Path, backend: str = "numpy"):
    """The generated ramp module, NumPy or compiled (``backend``: ``"numpy"`` or ``"c"``;
    progress on stderr; cached by content in ``out/cache``)."""
    out.mkdir(parents=True, exist_ok=True)
    desc = out / "middle_ear_ramp.yaml"
    text = ramp_description(data)
    if not desc.exists() or desc.read_text() != text:
        desc.write_text(text)
    with Tracker("generate") as track:
        return load_generated(generate(desc, out / "generated", progress=track,
                                       cache=out / "cache", backend=backend))


def parameters(mod, **values: float) -> np.ndarray:
    """The module's parameter vector with ``values`` set by name."""
    p = np.array(mod.default_parameters(), dtype=float)
    names = list(mod.PARAMETERS)
    for k, v in values.items():
        p[names.index(k)] = v
    return p


def steady_state(mod, p: np.ndarray, f: float) -> np.ndarray:
    """``[y, ẏ]`` at ``t = 0`` of the periodic response to ``Q = Q_amp sin(ωt)`` of the module
    linearized at ``t = 0``: ``y = Im(Y e^{iωt})``, ``Y = (Q − ω² M + iω P)⁻¹ B Q_amp``."""
    lin = linearize(mod, p=p, t=0.0)
    w = 2 * np.pi * f
    b = lin.B[:, list(lin.inputs).index("Q")] * p[list(mod.PARAMETERS).index("Q_amp")]
    Y = np.linalg.solve(lin.Q + 1j * w * lin.P - w * w * lin.M0, b)
    return np.concatenate((Y.imag, w * Y.real))


def amplitudes(mod, p: np.ndarray, f: float) -> dict[str, float]:
    """``|H(f)| |Q|`` of :data:`OUTPUTS` per input ``Q`` (:func:`neweul_py.analysis.frf`)."""
    fr = frf(mod, [f], "Q", list(OUTPUTS), p=p)
    q = p[list(mod.PARAMETERS).index("Q_amp")]
    return {k: float(abs(fr.H[0, i, 0])) * q for i, k in enumerate(OUTPUTS)}


def lock_in(t: np.ndarray, x: np.ndarray, f: float, samples: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude of the tone per period: ``|2/N Σ x e^{−iωt}|`` over consecutive windows of
    ``samples`` equally spaced points (one period each). Returns window centres, amplitudes."""
    n = (x.size - 1) // samples
    xs = x[:n * samples].reshape(n, samples)
    ts = t[:n * samples].reshape(n, samples)
    amp = np.abs(2.0 / samples * (xs * np.exp(-2j * np.pi * f * ts)).sum(axis=1))
    return ts.mean(axis=1), amp


@dataclass
class Run:
    """A simulated tone: output times, Δp(t), outputs by name, wall time and rhs calls."""

    t: np.ndarray
    dp: np.ndarray
    out: dict[str, np.ndarray]
    seconds: float
    nfev: int


def tone(mod, p: np.ndarray, t_end: float, f: float, steps_per_period: int,
         rho_inf: float, method: str = "generalized-alpha", per_period: int = 20) -> Run:
    """Simulate from the steady state at ``t = 0``; outputs at ``per_period`` points per period
    (on the steps of generalized-α: ``steps_per_period`` must be a multiple)."""
    x0 = steady_state(mod, p, f)
    n = x0.size // 2
    h = 1.0 / (f * steps_per_period)
    t_eval = np.arange(round(t_end * f * per_period) + 1) / (f * per_period)
    # the Newton tolerance in absolute terms: 1e-7 of the largest tone amplitude |Y| =
    # |x0 + i ẋ0/ω| of a coordinate (they span 1e-17 … 1e-6 m; a fixed small atol stalls
    # Newton's method at round-off once the amplitudes fall, as at Δp ≈ 1.3 kPa at refine 1),
    # and ω times that for the velocities (one atol for both asked the velocities for 1/ω of
    # their motion's digits: the +2 kPa check of the off-centre-umbo body stalled there)
    amp = np.abs(x0[:n] + 1j * x0[n:] / (2 * np.pi * f))
    atol = 1e-7 * float(amp.max()) * np.repeat([1.0, 2 * np.pi * f], n)
    kw = ({"h": h, "rho_inf": rho_inf, "rtol": 1e-6, "atol": atol}
          if method == "generalized-alpha" else {"rtol": 1e-6, "atol": atol, "max_step": h})
    with Tracker("simulate", unit="s") as track:
        t0 = time.perf_counter()
        res = simulate(mod, float(t_eval[-1]), method=method, t_eval=t_eval, p=p, x0=x0,
                       progress=track, **kw)
        seconds = time.perf_counter() - t0
    names = list(res.output_names)
    outs = np.asarray(res.outputs)
    pv = dict(zip(mod.PARAMETERS, p, strict=True))
    dp = pv["dp"] + pv["dp_ramp"] * np.sin(np.pi * res.t / pv["t_ramp"]) ** 2
    return Run(np.asarray(res.t), dp, {k: outs[:, names.index(k)] for k in OUTPUTS},
               seconds, int(getattr(res, "nfev", 0) or 0))


def check(mod, dp: float, f: float, periods: int, steps_per_period: int, rho_inf: float,
          q_amp: float, method: str = "generalized-alpha") -> tuple[dict[str, float], Run]:
    """Relative error of the last period's tone amplitude against ``|H(f)| |Q|`` at constant
    ``dp`` (module docstring, step 2)."""
    p = parameters(mod, dp=dp, dp_ramp=0.0, Q_amp=q_amp, f_tone=f)
    run = tone(mod, p, periods / f, f, steps_per_period, rho_inf, method)
    ref = amplitudes(mod, p, f)
    err = {}
    for k in OUTPUTS:
        _tc, amp = lock_in(run.t, run.out[k], f, 20)
        err[k] = abs(amp[-1] - ref[k]) / ref[k]
    return err, run


def quasi_static(mod, p: np.ndarray, f: float, dps: np.ndarray) -> dict[str, np.ndarray]:
    """``|H(f; Δp)| |Q|`` of :data:`OUTPUTS` at the frozen ``Δp`` values ``dps``."""
    rows = [amplitudes(mod, parameters(mod, **{**dict(zip(mod.PARAMETERS, p, strict=True)),
                                               "dp": d, "dp_ramp": 0.0}), f) for d in dps]
    return {k: np.array([r[k] for r in rows]) for k in OUTPUTS}


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    """One column per entry (header = the keys, units in the names)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(columns))
        w.writerows(np.column_stack(list(columns.values())).tolist())


def plot(path: Path, run: Run, env: dict[str, np.ndarray], qs_dp: np.ndarray,
         qs: dict[str, np.ndarray], title: str) -> None:
    """Δp(t); umbo and stapes velocity (trace, simulated envelope, quasi-static envelope)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    ms = 1e3 * run.t
    ax[0].plot(ms, run.dp, "k")
    ax[0].set_ylabel("Δp(t) [Pa]")
    ax[0].set_title(title, fontsize=9)
    for a, key, label in ((ax[1], "umbo_velocity_z", "umbo"),
                          (ax[2], "stapes_velocity", "stapes")):
        a.plot(ms, 1e3 * run.out[key], color="0.75", lw=0.3, label=f"{label} velocity")
        a.plot(1e3 * env["t"], 1e3 * env[key], "b", lw=1.2, label="envelope (simulated)")
        a.plot(1e3 * env["t"], 1e3 * np.interp(env["dp"], qs_dp, qs[key]), "r--", lw=1.0,
               label="quasi-static |H(f; Δp(t))|·|Q|")
        a.set_ylabel(f"{label} velocity [mm/s]")
        a.legend(fontsize=7, loc="upper center")
        a.grid(True, lw=0.3)
    ax[2].set_xlabel("t [ms]")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True,
                    help="a build of neweul middle-ear build (read only)")
    ap.add_argument("--out", type=Path, default=None,
                    help="traces, tables, generated module (default DIR/time_study)")
    ap.add_argument("--plot", type=Path, default=None,
                    help="the figure (default OUT/embs_ramp.png; the README's is "
                    "examples/middle_ear/embs_ramp.png)")
    ap.add_argument("--f-tone", type=float, default=1000.0, help="tone [Hz] (default 1000)")
    ap.add_argument("--q-amp", type=float, default=1e-5, help="tone amplitude [m^3/s^2]")
    ap.add_argument("--dp-peak", type=float, default=2000.0,
                    help="ramp amplitude [Pa] (default 2000: a middle-ear pressure of -2 kPa)")
    ap.add_argument("--t-ramp", type=float, default=0.35,
                    help="ramp duration [s] (default 0.35; e.g. 0.02 for a quick run)")
    ap.add_argument("--steps-per-period", type=int, default=100,
                    help="generalized-alpha steps per tone period (default 100)")
    ap.add_argument("--rho-inf", type=float, default=0.5,
                    help="spectral radius at infinity (default 0.5, the value the README's "
                    "measurements use; 0.8 converges too since the per-state tolerances)")
    ap.add_argument("--method", default="generalized-alpha")
    ap.add_argument("--backend", choices=("c", "numpy"), default="c",
                    help="the generated module: compiled (default; needs a C compiler) or NumPy")
    ap.add_argument("--check-periods", type=int, default=10,
                    help="periods of the check at constant dp (default 10)")
    ap.add_argument("--check-only", action="store_true",
                    help="only the check at constant dp against the FRF (seconds)")
    args = ap.parse_args()
    build_record(args.dir, 0.0, args.dp_peak)
    out = args.out or args.dir / "time_study"
    args.plot = args.plot or out / "embs_ramp.png"
    f, spp = args.f_tone, args.steps_per_period
    wall = time.perf_counter()
    t0 = time.perf_counter()
    mod = ramp_module(args.dir, out, args.backend)
    t_gen = time.perf_counter() - t0
    print(f"module: {mod.STATE_SIZE} states, generated/loaded in {t_gen:.0f} s", flush=True)
    lines = ["# Middle-ear EMBS time study (examples/middle_ear/time_study.py)", "",
             f"data {args.dir}; {mod.STATE_SIZE} states; tone {f:g} Hz, |Q| = {args.q_amp:g} "
             f"m³/s²; {args.method}, h = T/{spp}, ρ∞ = {args.rho_inf:g}", "",
             "## Check at constant Δp (from the steady state, last of "
             f"{args.check_periods} periods, against |H(f)|·|Q| of frf)", "",
             "| Δp [Pa] | " + " | ".join(OUTPUTS) + " | wall [s] | rhs calls |",
             "|---" * (len(OUTPUTS) + 3) + "|"]
    for dp in (0.0, args.dp_peak):
        err, run = check(mod, dp, f, args.check_periods, spp, args.rho_inf, args.q_amp,
                         args.method)
        lines.append(f"| {dp:+.0f} | " + " | ".join(f"{100 * err[k]:.3f} %" for k in OUTPUTS)
                     + f" | {run.seconds:.1f} | {run.nfev} |")
        print(lines[-1], flush=True)
    if args.check_only:
        print("\n".join(lines))
        return
    p = parameters(mod, dp=0.0, dp_ramp=args.dp_peak, t_ramp=args.t_ramp, Q_amp=args.q_amp,
                   f_tone=f)
    run = tone(mod, p, args.t_ramp, f, spp, args.rho_inf, args.method)
    env = {"t": lock_in(run.t, run.dp, f, 20)[0], "dp": lock_in(run.t, run.dp, f, 20)[0]}
    env["dp"] = np.interp(env["t"], run.t, run.dp)
    for k in OUTPUTS:
        env[k] = lock_in(run.t, run.out[k], f, 20)[1]
    qs_dp = np.linspace(0.0, args.dp_peak, 21)
    qs = quasi_static(mod, p, f, qs_dp)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "time_traces.csv", {"t_s": run.t, "dp_Pa": run.dp,
                                        "umbo_velocity_z_m_per_s": run.out["umbo_velocity_z"],
                                        "stapes_velocity_m_per_s": run.out["stapes_velocity"],
                                        "p_probe_Pa": run.out["p_probe"]})
    qs_env = {k: np.interp(env["dp"], qs_dp, qs[k]) for k in OUTPUTS}
    write_csv(out / "time_envelope.csv", {
        "t_s": env["t"], "dp_Pa": env["dp"],
        **{f"{k}_amplitude": env[k] for k in OUTPUTS},
        **{f"{k}_quasi_static": qs_env[k] for k in OUTPUTS}})
    dev = {k: float(np.max(np.abs(env[k] - qs_env[k]) / qs_env[k])) for k in OUTPUTS}
    lines += ["", f"## Ramp Δp = {args.dp_peak:g} sin²(πt/{args.t_ramp:g} s) Pa: "
              f"{run.seconds:.0f} s wall, {run.nfev} rhs calls", "",
              "| t [ms] | Δp [Pa] | umbo [mm/s] | quasi-static | stapes [mm/s] | quasi-static |"
              " p_probe [Pa] | quasi-static |", "|---|---|---|---|---|---|---|---|"]
    for frac in (0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0):
        i = min(int(frac * (env["t"].size - 1)), env["t"].size - 1)
        lines.append(f"| {1e3 * env['t'][i]:.1f} | {env['dp'][i]:.0f} | "
                     + " | ".join(f"{s * env[k][i]:.4g} | {s * qs_env[k][i]:.4g}"
                                  for k, s in (("umbo_velocity_z", 1e3),
                                               ("stapes_velocity", 1e3), ("p_probe", 1.0)))
                     + " |")
    lines += ["", "Largest deviation of the simulated envelope from the quasi-static one: "
              + ", ".join(f"{k} {100 * v:.2f} %" for k, v in dev.items()),
              "", f"Wall time in all: {time.perf_counter() - wall:.0f} s"]
    (out / "time_results.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    plot(args.plot, run, env, qs_dp, qs,
         f"1 kHz tone, Δp = {args.dp_peak:g} sin²(πt/{1e3 * args.t_ramp:g} ms) Pa "
         f"({args.dir.name}, {args.method}, h = T/{spp})")
    print(f"wrote {out} and {args.plot}")


if __name__ == "__main__":
    main()
