"""What the middle-ear build samples: interface loads, static states, coordinate, refinement.

The parametric TM + air body of the middle ear is built from the FE models of working points
of the pressure sweep (docs/equations-middle-ear.md §5–7):

* :func:`interface_loads` — the loads the body must answer to: the canal sound source and the
  six rigid motions of the malleus seen through the TM–manubrium springs, with the adjoint
  outputs (probe pressure, umbo, malleus loads); the snapshots of the reduction basis;
* :func:`static_states` — per working point the static state the body carries (the FE
  static state, the malleus forces on the manubrium, the exact swept volume);
* :func:`volume_coordinate` — the TM's static volume displacement as the interpolation
  coordinate (docs/equations.md §4.1);
* :func:`refine` — greedy sampling: working points are added where the interpolated body
  differs from the FE model projected there by more than a tolerance (:func:`indicator`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sps

from ..elastic.fe_model import FEModel
from ..elastic.io.working_point import read_static
from ..elastic.parametric.samples import coordinate_table
from ..elastic.quality.measures import frf_reduced
from ..errors import DataError
from .chain import malleus_map
from .embs import model_path

__all__ = [
    "INDICATOR_HZ",
    "MIN_INTERVAL",
    "indicator",
    "interface_loads",
    "refine",
    "static_states",
    "swept_volumes",
    "volume_coordinate",
]

#: Frequencies of the refinement indicator [Hz].
INDICATOR_HZ = np.geomspace(100.0, 5000.0, 24)
#: Narrowest interval the refinement splits [Pa] (file names hold whole pascals).
MIN_INTERVAL = 125.0
#: The canal source and the outputs of the adjoint snapshots.
SOURCE = "canal_volume_acceleration"
OUTPUTS = ("probe_pressure", "umbo_uz")
#: The pars flaccida's output (present with ``pf_compliance > 0``): its DOF takes a unit load.
FLACCIDA = "pf_volume_displacement"


def manubrium_inputs(fe: FEModel) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The manubrium inputs ``manubrium.<id>.u?`` of a working point (in the FE model's order),
    their DOFs and node ids."""
    names = [name for name in fe.inputs if name.startswith("manubrium.")]
    dofs = np.array([fe.inputs[name][0][0] for name in names], dtype=np.int64)
    nodes = np.array([int(name.split(".")[1]) for name in names], dtype=np.int64)
    return names, dofs, nodes


def interface_loads(fe: FEModel, umbo: int, k_attach: float
                    ) -> tuple[sps.csr_matrix, np.ndarray, np.ndarray]:
    """``K_x`` (the TM–manubrium springs to ground, ``k_attach`` in all, equal per manubrium
    node), the loads ``[b_canal, K_x T]`` and the output rows (transposed)
    ``[c_probe, c_umbo, K_x T]`` of the adjoint snapshots; ``T`` the rigid malleus map about
    the umbo node (:func:`~neweul_py.middle_ear.chain.malleus_map`) in the rows of the
    manubrium inputs. With a pars flaccida (output ``pf_volume_displacement``) both also hold
    a unit force on its DOF: its stiffness varies fast with ``Δp``, and by Sherman–Morrison
    the response of a working point with another pars-flaccida stiffness lies in the span of
    the responses to the canal source and to that force (docs/equations-middle-ear.md §8)."""
    names, dofs, nodes = manubrium_inputs(fe)
    k = k_attach / (dofs.size // 3)
    n = fe.n_dofs
    Kx = sps.csr_matrix((np.full(dofs.size, k), (dofs, dofs)), shape=(n, n))
    xyz = {int(r[0]): np.asarray(r[1:4], dtype=float) for r in fe.nodes}
    order = sorted(set(nodes.tolist()), key=nodes.tolist().index)
    T3 = malleus_map(np.array([xyz[i] for i in order]), np.arange(len(order)), xyz[int(umbo)])
    row = {(node, "xyz"[a]): 3 * j + a for j, node in enumerate(order) for a in range(3)}
    T = T3[[row[(int(name.split(".")[1]), name[-1])] for name in names]]
    pf = [i for i, _ in fe.outputs.get(FLACCIDA, ())]
    F = np.zeros((n, 7 + len(pf)))
    F[:, 0] = fe.B(SOURCE)[:, 0]
    F[dofs, 1:7] = k * T
    F[pf, 7:] = np.eye(len(pf))
    Cadj = np.zeros((n, 8 + len(pf)))
    for j, name in enumerate(OUTPUTS):
        for i, w in fe.outputs[name]:
            Cadj[i, j] += w
    Cadj[:, 2:] = F[:, 1:]
    return Kx, F, Cadj


def swept_volumes(paths: Iterable[Path]) -> dict[float, float]:
    """``Δp → V``: the exact swept volume of the rows of sweeps' ``static.csv`` (or
    ``static_curve.csv``) files ``paths``."""
    volume: dict[float, float] = {}
    for path in paths:
        rows = np.genfromtxt(path, delimiter=",", names=True)
        volume |= dict(zip(np.atleast_1d(rows["dp_Pa"]).tolist(),
                           np.atleast_1d(rows["volume_displacement_m3"]).tolist(), strict=True))
    return volume


def volume_coordinate(where: Mapping[float, Path], curve: Path, points: Sequence[float]
                      ) -> np.ndarray:
    """The (2, n) volume-coordinate table of a body of the working points ``points``
    (docs/equations.md §4.1): the static curve ``curve`` and the exact swept volume of every
    known working point (``static.csv`` of each sweep directory in ``where``)."""
    table = swept_volumes([curve, *sorted({d / "static.csv" for d in where.values()})])
    sig = np.array(sorted(table))
    return coordinate_table(np.sort(np.asarray(points, dtype=float)), sig,
                            np.array([table[v] for v in sig]), str(curve))


def static_states(where: Mapping[float, Path], pressures: Iterable[float],
                  manubrium: Sequence[int]) -> list[dict[str, Any]]:
    """Per working point (in the sweep directory ``where[p]``) the static state the body
    carries (docs/equations-middle-ear.md §5): the FE file's ``static_x``, the static forces of
    the malleus on the manubrium nodes, and the exact nonlinear swept volume (``static.csv``) as
    the static value of the body's ``tm_volume_displacement`` output (its row applied to
    ``x_s`` is only the linearized volume).

    Raises
    ------
    DataError
        A working point without a static group, or whose malleus forces act on other nodes
        than ``manubrium``.
    """
    volume = swept_volumes(d / "static.csv" for d in set(where.values()))
    out = []
    for p in pressures:
        path = model_path(where[float(p)], p)
        st = read_static(path)
        if st is None or float(p) not in volume:
            raise DataError("the working point carries no static state (static_* arrays, "
                            "static.csv): rebuild it with neweul fem middle-ear", str(path),
                            "static_x")
        ids = [int(i) for i in st["manubrium_node_id"]]
        if sorted(ids) != sorted(int(i) for i in manubrium):
            raise DataError(f"static forces at nodes {ids}, the body's manubrium nodes are "
                            f"{list(manubrium)}", str(path), "static_manubrium_node_id")
        out.append({"x": st["x"], "node_force": dict(zip(ids, st["manubrium_force"],
                                                         strict=True)),
                    "outputs": {"tm_volume_displacement": volume[float(p)]}})
    return out


def indicator(body: Any, ref: Any, phi: np.ndarray, k_node: float) -> float:
    """Max relative difference of two bodies' transfer functions (canal source → probe
    pressure, umbo) over :data:`INDICATOR_HZ`, with the manubrium free and held by the
    TM–manubrium springs ``k_node`` at the node rows ``phi`` (the two ends of what a chain
    does): the interpolation error indicator of :func:`refine`."""
    err = 0.0
    for k in (0.0, k_node):
        h = [frf_reduced(x.with_(K=x.K + k * phi.T @ phi), INDICATOR_HZ, SOURCE, list(OUTPUTS))
             for x in (body, ref)]
        err = max(err, float(np.max(np.abs(h[0] - h[1]) / np.abs(h[1]))))
    return err


def refine(samples: Sequence[float], body_of: Callable[[list[float]], Any], tol: float,
           phi: np.ndarray, k_node: float, more_models: Callable[[list[float]], None],
           progress: Callable[..., None], min_interval: float = MIN_INTERVAL) -> np.ndarray:
    """The working points with samples added where the parametric body misses (greedy
    sampling, e.g. Haasdonk 2017, *Reduced basis methods*, §2.4): at the middle of every
    interval the FE model is built (``more_models(points)``), projected on the basis and
    compared with the body interpolated there (:func:`indicator`); where they differ by more
    than ``tol`` the middle becomes a sample. Repeated until every interval passes or is
    ``min_interval`` wide (default :data:`MIN_INTERVAL`). ``body_of(points)`` is the
    parametric body of the samples ``points`` (a single point: that working point's body)."""
    s = np.array(samples, dtype=float)
    passed: set[tuple[float, float]] = set()
    rounds = 0
    while True:
        todo = [(a, b) for a, b in itertools.pairwise(s)
                if (a, b) not in passed and b - a >= 2 * min_interval]
        if not todo:
            return s
        rounds += 1
        mids = [0.5 * (a + b) for a, b in todo]
        more_models(mids)
        pb = body_of(list(s))
        added = []
        for i, ((a, b), m) in enumerate(zip(todo, mids, strict=True)):
            e = indicator(pb.at(m), body_of([m]), phi, k_node)
            progress(f"refinement {rounds}", i + 1, len(todo))
            progress(f"  {m:+7.1f} Pa (between {a:+.0f} and {b:+.0f}): indicator {e:.2e}"
                     + (" → sample" if e > tol else ""))
            (added.append(m) if e > tol else passed.add((a, b)))
        if not added:
            return s
        s = np.sort(np.r_[s, added])
