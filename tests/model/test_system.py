"""Validation of the model layer (System construction checks, key paths)."""

import pytest
import sympy as sp

from neweul_py.errors import ModelError
from neweul_py.model import (
    Coordinate,
    ExpressionOutput,
    Frame,
    GeneralizedForce,
    Parameter,
    RigidBody,
    System,
    symbol,
)

phi, l, m, g = (symbol(n) for n in ("phi", "l", "m", "g"))


def pendulum(**overrides):
    kwargs = dict(
        coordinates=(Coordinate("phi", 0.1),),
        parameters=(Parameter("l", 1.0), Parameter("m", 2.0), Parameter("g", 9.81)),
        frames=(Frame("arm", rotation=(("z", phi),)),),
        bodies=(RigidBody("bob", "arm", m, sp.ImmutableMatrix([l, 0, 0])),),
        gravity=sp.ImmutableMatrix([0, -g, 0]),
    )
    kwargs.update(overrides)
    return System("pendulum", **kwargs)


def test_valid_system_is_frozen_and_fingerprinted():
    s = pendulum()
    assert s.fingerprint() == pendulum().fingerprint()
    assert s.fingerprint() != pendulum(parameters=(
        Parameter("l", 2.0), Parameter("m", 2.0), Parameter("g", 9.81))).fingerprint()
    with pytest.raises(AttributeError):
        s.name = "other"  # type: ignore[misc]


def test_frame_cycle_named():
    with pytest.raises(ModelError, match=r"frame cycle: a -> b -> a") as err:
        System("x", frames=(Frame("a", "b"), Frame("b", "a")))
    assert err.value.key_path == "frames.a.parent"


def test_unknown_parent_lists_frames():
    with pytest.raises(ModelError, match=r"unknown parent frame 'nope'.*ISYS"):
        System("x", frames=(Frame("a", "nope"),))


def test_unknown_symbol_lists_allowed_names():
    with pytest.raises(ModelError) as err:
        pendulum(frames=(Frame("arm", rotation=(("z", symbol("psi")),)),))
    assert err.value.key_path == "frames.arm.rotation[0][1]"
    assert "'psi'" in str(err.value) and "phi" in str(err.value)


def test_mass_may_not_use_coordinates():
    with pytest.raises(ModelError, match="unknown name 'phi'"):
        pendulum(bodies=(RigidBody("bob", "arm", m * phi),))


def test_negative_mass_rejected():
    with pytest.raises(ModelError, match="must not be negative") as err:
        pendulum(bodies=(RigidBody("bob", "arm", -m),))
    assert err.value.key_path == "bodies.bob.mass"


def test_nonsymmetric_inertia_rejected():
    inertia = sp.ImmutableMatrix([[1, 0.1, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ModelError, match="symmetric") as err:
        RigidBody("b", "arm", m, inertia=inertia)
    assert err.value.key_path == "bodies.b.inertia[0][1]"


@pytest.mark.parametrize(
    "diag", [(-1.0, 1.0, 1.0), (1.0, 1.0, 3.0)], ids=["negative", "triangle"]
)
def test_unphysical_inertia_rejected(diag):
    with pytest.raises(ModelError, match=r"inertia|principal"):
        pendulum(bodies=(RigidBody("bob", "arm", m, inertia=sp.ImmutableMatrix(sp.diag(*diag))),))


def test_symmetric_eigenvalues3_matches_numpy():
    """The Jacobi eigenvalues of the inertia check agree with LAPACK's ``eigvalsh`` to
    round-off (reference: numpy.linalg.eigvalsh) on random, rank-deficient, nearly degenerate
    and badly scaled symmetric matrices; a diagonal matrix gives its diagonal exactly."""
    import numpy as np

    from neweul_py.model.system import symmetric_eigenvalues3

    rng = np.random.default_rng(3)
    for k in range(600):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        d = rng.choice([0.0, 1.0, 1e-8, 2.0, 1.0 + 1e-12], 3) if k % 2 else rng.normal(size=3)
        a = q @ np.diag(d) @ q.T
        a = 0.5 * (a + a.T) * 10.0 ** rng.integers(-150, 150)
        ref = np.linalg.eigvalsh(a)
        got = np.array(symmetric_eigenvalues3(a.tolist()))
        assert np.max(np.abs(got - ref)) <= 1e-14 * np.max(np.abs(ref))
    assert symmetric_eigenvalues3([[2, 0, 0], [0, 0.1, 0], [0, 0, 3]]) == (0.1, 2.0, 3.0)
    assert symmetric_eigenvalues3([[0, 0, 0]] * 3) == (0.0, 0.0, 0.0)


def test_rotated_rod_inertia_is_accepted():
    """A thin rod's inertia diag(0, I, I) turned 30° about z (principal moments 0, I, I:
    on the boundary of the triangle inequality and of semidefiniteness) is a valid body."""
    c, s = sp.cos(sp.pi / 6), sp.sin(sp.pi / 6)
    r = sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    inertia = sp.ImmutableMatrix(r * sp.diag(0, 2, 2) * r.T)
    pendulum(bodies=(RigidBody("bob", "arm", m, inertia=inertia),))
    with pytest.raises(ModelError, match="positive semidefinite"):
        pendulum(bodies=(RigidBody("bob", "arm", m,
                                   inertia=sp.ImmutableMatrix(r * sp.diag(-0.1, 2, 2) * r.T)),))


def test_duplicate_and_reserved_names():
    with pytest.raises(ModelError, match="already used"):
        pendulum(parameters=(Parameter("l", 1.0), Parameter("m", 1.0), Parameter("g", 1.0),
                             Parameter("phi", 1.0)))
    with pytest.raises(ModelError, match="reserved"):
        pendulum(coordinates=(Coordinate("sin"),))
    with pytest.raises(ModelError, match="velocities"):
        pendulum(coordinates=(Coordinate("d_x"),))


def test_non_finite_parameter_rejected():
    with pytest.raises(ModelError, match="finite"):
        pendulum(parameters=(Parameter("l", float("nan")), Parameter("m", 1.0),
                             Parameter("g", 1.0)))


def test_bool_parameter_default_rejected():
    with pytest.raises(ModelError, match="finite number"):
        pendulum(parameters=(Parameter("l", True), Parameter("m", 1.0), Parameter("g", 1.0)))


def test_generalized_force_unknown_coordinate():
    with pytest.raises(ModelError, match="unknown coordinate 'psi'"):
        pendulum(forces=(GeneralizedForce("f", "psi", sp.Integer(1)),))


def test_output_may_use_velocities():
    s = pendulum(outputs=(ExpressionOutput("omega", symbol("d_phi") * l),))
    assert s.outputs[0].name == "omega"


def test_frame_chain_and_topological_order():
    s = System("x", frames=(Frame("c", "b"), Frame("b", "a"), Frame("a")))
    assert [f.name for f in s.frame_chain("c")] == ["a", "b", "c"]
    assert [f.name for f in s.frames_topological] == ["a", "b", "c"]


def test_parameter_ranges_are_checked_and_implied_by_rest_lengths():
    """A parameter may carry an admissible range (inclusive bounds); its default must lie in
    it. A parameter that is by itself a spring's rest length is at least 0 (the rule the
    model applies to the rest length at the defaults). Reference: the ranges written here."""
    from neweul_py.model import SpringDamper

    s = pendulum(parameters=(Parameter("l", 1.0, minimum=0.0), Parameter("m", 2.0),
                             Parameter("g", 9.81, minimum=9.0, maximum=10.0)))
    assert s.parameter_ranges == {"l": (0.0, None), "g": (9.0, 10.0)}
    with pytest.raises(ModelError, match=r"default 1 is outside its range 2 … 3") as err:
        Parameter("l", 1.0, minimum=2.0, maximum=3.0)
    assert err.value.key_path == "parameters.l"
    with pytest.raises(ModelError, match="minimum 3 is above its maximum 2"):
        Parameter("l", 2.5, minimum=3.0, maximum=2.0)
    with pytest.raises(ModelError, match="must be a finite number"):
        Parameter("l", 1.0, minimum=float("nan"))
    spring = SpringDamper("s", "ISYS", "arm", length=l, stiffness=sp.Integer(1))
    assert pendulum(forces=(spring,)).parameter_ranges == {"l": (0.0, None)}
    ranged = pendulum(parameters=(Parameter("l", 1.0, minimum=0.5), Parameter("m", 2.0),
                                  Parameter("g", 9.81)), forces=(spring,))
    assert ranged.parameter_ranges == {"l": (0.5, None)}
