#!/usr/bin/env python3
"""Peer side of bench_compiled.py (d): a Hex20 flexible pendulum in Exudyn.

Runs in a separate peer environment (exudyn, scikit-fem; never a dependency of neweul-py). The body
is a block ``L × a × a`` (L = 1 m, a = 0.05 m, aluminium: E = 70 GPa, ν = 0.3, ρ = 2700 kg/m³)
meshed by scikit-fem with ``ElementHexS2`` (20-node serendipity hex, ``nx × 2 × 2`` elements),
linear elasticity M and K assembled there and handed to Exudyn's ``FEMinterface``;
Hurty–Craig–Bampton modes with one RBE2 interface at the hinge end (its rigid motion excluded: the
floating frame), ``ObjectFFRFreducedOrder`` with ``--modes`` eigenmodes, hinged at x = 0 about the y
axis by a ``GenericJoint`` on a ``MarkerSuperElementRigid``, gravity −z, released horizontally from
rest, 1 s of generalized-α with h = 1e-3 (Exudyn's default implicit solver). Prints JSON on the last
line: mesh and mode times, the wall time of ``SolveDynamic`` and the tip displacement at t = 1 s.
"""

from __future__ import annotations

import json
import sys
import time


def fe_model(nx: int):
    """Nodes (np, 3), 20-node connectivity, CSR mass and stiffness (3 np) of the block."""
    import numpy as np
    import skfem
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    L, a, E, nu, rho = 1.0, 0.05, 70e9, 0.3, 2700.0
    mesh = skfem.MeshHex.init_tensor(np.linspace(0, L, nx + 1), np.linspace(-a / 2, a / 2, 3),
                                     np.linspace(-a / 2, a / 2, 3))
    scalar = skfem.Basis(mesh, skfem.ElementHexS2(), intorder=4)
    vector = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementHexS2()), intorder=4)
    K = skfem.asm(linear_elasticity(*lame_parameters(E, nu)), vector)

    @skfem.BilinearForm
    def mass(u, v, w):
        return rho * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2])

    M = skfem.asm(mass, vector)
    # Exudyn wants point-major coordinates [x0, y0, z0, x1, …]: vector dof 3j + c ↔ point j
    pts = scalar.doflocs.T
    order = np.empty(3 * pts.shape[0], dtype=int)
    for c in range(3):
        comp = vector.doflocs[:, c::3].T
        assert np.allclose(comp, pts)  # skfem interleaves the components of each point
        order[c::3] = np.arange(c, vector.N, 3)
    K = K[order][:, order].tocsr()
    M = M[order][:, order].tocsr()
    return pts, M, K, L


def run(nx: int, modes: int) -> dict:
    import exudyn as exu
    import numpy as np
    from exudyn.FEM import (
        FEMinterface,
        HCBstaticModeSelection,
        ObjectFFRFreducedOrderInterface,
    )
    from exudyn.itemInterface import (
        GenericJoint,
        MarkerBodyRigid,
        MarkerSuperElementRigid,
        ObjectGround,
        VObjectJointGeneric,
    )

    t0 = time.perf_counter()
    pts, M, K, L = fe_model(nx)
    fem = FEMinterface()
    fem.nodes = {"Position": pts}
    fem.massMatrix = M  # Exudyn ≥ 1.8 stores scipy CSR matrices (useOldCSRformat = False)
    fem.stiffnessMatrix = K
    hinge = [int(i) for i in np.flatnonzero(np.isclose(pts[:, 0], 0.0))]
    t1 = time.perf_counter()
    fem.ComputeHurtyCraigBamptonModes(boundaryNodesList=[hinge], nEigenModes=modes,
                                      useSparseSolver=True,
                                      computationMode=HCBstaticModeSelection.RBE2)
    t2 = time.perf_counter()
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    cms = ObjectFFRFreducedOrderInterface(fem)
    obj = cms.AddObjectFFRFreducedOrder(mbs, positionRef=[0, 0, 0], initialVelocity=[0, 0, 0],
                                        initialAngularVelocity=[0, 0, 0],
                                        gravity=[0, 0, -9.81])
    body = obj["oFFRFreducedOrder"]
    weights = np.full(len(hinge), 1.0 / len(hinge))
    m_hinge = mbs.AddMarker(MarkerSuperElementRigid(bodyNumber=body, offset=[0, 0, 0],
                                                     meshNodeNumbers=np.array(hinge),
                                                     weightingFactors=weights))
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    m_ground = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
    mbs.AddObject(GenericJoint(markerNumbers=[m_ground, m_hinge],
                               constrainedAxes=[1, 1, 1, 1, 0, 1],
                               visualization=VObjectJointGeneric(show=False)))
    mbs.Assemble()
    settings = exu.SimulationSettings()
    settings.timeIntegration.endTime = 1.0
    settings.timeIntegration.numberOfSteps = 1000
    settings.timeIntegration.verboseMode = 0
    settings.timeIntegration.newton.useModifiedNewton = True
    settings.solution.file.write = False
    settings.show.computationTime = False
    t3, c3 = time.perf_counter(), time.process_time()
    exu.SolveDynamic(mbs, settings)
    t4, c4 = time.perf_counter(), time.process_time()
    tip = int(np.argmin(np.linalg.norm(pts - [L, 0, 0], axis=1)))
    pos = mbs.GetObjectOutputSuperElement(body, exu.OutputVariableType.Position,
                                          meshNodeNumber=tip)
    return {"nodes": int(pts.shape[0]), "dofs": int(3 * pts.shape[0]), "modes": modes,
            "mesh_assembly": t1 - t0, "modes_time": t2 - t1, "solve": t4 - t3, "solve_cpu": c4 - c3,
            "tip": [float(v) for v in pos]}


if __name__ == "__main__":
    args = sys.argv[1:]
    print(json.dumps(run(int(args[0]) if args else 16, int(args[1]) if len(args) > 1 else 10)))
