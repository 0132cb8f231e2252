"""Generated modules as typed models: loading by path, checking the protocol, and the one view
of a module the analysis reads (:class:`GeneratedModel`).

The analysis layer never imports sympy or the symbolic layers; it works on modules written by
``neweul generate`` through the generated-module protocol (docs/generated-module-protocol.md),
and only through :class:`GeneratedModel`: the protocol's constants and functions as attributes
(the optional ones filled in), what the model can do as properties.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import NeweulError
from ..files import generated_module_name, read_checked

__all__ = [
    "MAX_MODULE_BYTES",
    "SUPPORTED_PROTOCOL_VERSIONS",
    "GeneratedModel",
    "ModelLike",
    "as_model",
    "check_protocol",
    "load_generated",
]

#: Largest generated module read (bytes; a module of a big model is a few MB).
MAX_MODULE_BYTES = 512 * 2**20

#: Protocol versions this package can read.
SUPPORTED_PROTOCOL_VERSIONS = (1,)

_CONSTANTS: dict[str, type | tuple[type, ...]] = {
    "PROTOCOL_VERSION": int,
    "MODEL_NAME": str,
    "COORDINATES": list,
    "INITIAL_STATE": list,
    "PARAMETERS": dict,
    "INPUTS": list,
    "OUTPUTS": list,
    "CONSTRAINTS": list,
    "STATE_SIZE": int,
    "SOURCE_HASH": str,
    "MASS_MATRIX_SYMMETRIC": bool,
}
_FUNCTIONS = (
    "default_parameters",
    "default_inputs",
    "mass_matrix",
    "force_vector",
    "rhs",
    "force_jacobians",
    "mass_matrix_times_derivative",
    "rhs_jacobian",
    "outputs",
    "output_jacobians",
    "constraints",
    "constraint_jacobian",
    "constraint_gamma",
)


def check_protocol(module: Any, where: str | None = None) -> None:
    """Raise :class:`NeweulError` unless ``module`` implements the generated-module protocol.

    Checks the presence and types of the constants, their consistency (``STATE_SIZE`` ≥ 2n,
    ``INITIAL_STATE`` of length ``STATE_SIZE``, string names) and that the functions exist.
    """
    where = where or getattr(module, "__file__", None) or getattr(module, "__name__", "module")
    for name, kind in _CONSTANTS.items():
        if not hasattr(module, name):
            raise NeweulError(
                f"{where}: not a generated module (missing {name}; see "
                "docs/generated-module-protocol.md)"
            )
        if not isinstance(getattr(module, name), kind) or (
            kind is int and isinstance(getattr(module, name), bool)
        ):
            raise NeweulError(f"{where}: {name} has the wrong type")
    if module.PROTOCOL_VERSION not in SUPPORTED_PROTOCOL_VERSIONS:
        raise NeweulError(
            f"{where}: protocol version {module.PROTOCOL_VERSION} is not supported (this "
            f"neweul-py reads {', '.join(map(str, SUPPORTED_PROTOCOL_VERSIONS))}); regenerate it"
        )
    n = len(module.COORDINATES)
    for name in ("COORDINATES", "INPUTS", "OUTPUTS", "CONSTRAINTS"):
        if not all(isinstance(s, str) for s in getattr(module, name)):
            raise NeweulError(f"{where}: {name} must hold names (strings)")
    if module.STATE_SIZE < 2 * n or len(module.INITIAL_STATE) != module.STATE_SIZE:
        raise NeweulError(
            f"{where}: STATE_SIZE {module.STATE_SIZE} does not fit {n} coordinates and an "
            f"initial state of length {len(module.INITIAL_STATE)}"
        )
    missing = [f for f in _FUNCTIONS if not callable(getattr(module, f, None))]
    if missing:
        raise NeweulError(f"{where}: not a generated module (missing {', '.join(missing)})")


Function = Callable[..., Any]


@dataclass(frozen=True, eq=False, repr=False)
class GeneratedModel:
    """A generated module through its protocol (docs/generated-module-protocol.md).

    The attributes carry the protocol's names: the constants (``COORDINATES``, ``PARAMETERS``,
    ``CONSTRAINTS`` …) and functions (``rhs``, ``mass_matrix`` …) of the module, so
    ``model.rhs(t, x, p)`` calls the module's ``rhs``. Optional constants are filled in
    (``COORDINATE_UNITS``, ``OUTPUT_UNITS``, ``INPUT_UNITS``, ``FRAMES``, ``BODIES`` …: empty
    lists, ``INPUT_RATES``, ``PARAMETER_RANGES``: ``{}``, ``BACKEND``: ``"numpy"``,
    ``BACKEND_ERROR``: ``""``, ``LOSS_REFERENCE_FREQUENCY``: ``None``); optional functions
    are ``None`` where the module has none. What the model can do is asked of the properties
    (:attr:`has_constraints`, :attr:`compiled` …), never of the module. Create it with
    :func:`load_generated` (a path) or :func:`as_model` (a path, a module or any object with the
    protocol's names).
    """

    module: Any
    path: str
    # constants
    PROTOCOL_VERSION: int
    MODEL_NAME: str
    DESCRIPTION: str
    COORDINATES: list[str]
    COORDINATE_UNITS: list[str]
    INITIAL_STATE: list[float]
    PARAMETERS: dict[str, float]
    PARAMETER_RANGES: dict[str, tuple[float | None, float | None]]
    INPUTS: list[str]
    INPUT_UNITS: list[str]
    INPUT_RATES: dict[str, list[str]]
    OUTPUTS: list[str]
    OUTPUT_UNITS: list[str]
    CONSTRAINTS: list[str]
    STATE_SIZE: int
    SOURCE_HASH: str
    MASS_MATRIX_SYMMETRIC: bool
    ENERGY: list[str]
    LOSS_REFERENCE_FREQUENCY: float | None
    FRAMES: list[str]
    FRAME_PARENTS: list[str]
    BODIES: list[dict[str, Any]]
    BACKEND: str
    BACKEND_NOTE: str
    BACKEND_ERROR: str
    # functions
    default_parameters: Function
    default_inputs: Function
    mass_matrix: Function
    force_vector: Function
    rhs: Function
    force_jacobians: Function
    mass_matrix_times_derivative: Function
    rhs_jacobian: Function
    outputs: Function
    output_jacobians: Function
    constraints: Function
    constraint_jacobian: Function
    constraint_gamma: Function
    # optional functions
    constraint_reaction_jacobian: Function | None = None
    constraint_time_derivative: Function | None = None
    energy: Function | None = None
    loss_matrix: Function | None = None
    frame_poses: Function | None = None
    body_properties: Function | None = None
    node_positions: Function | None = None
    integrate_dopri5: Function | None = None
    generalized_alpha_steps: Function | None = None
    # parameter derivatives (docs/sensitivity.md)
    default_inputs_parameter_jacobian: Function | None = None
    force_parameter_jacobian: Function | None = None
    mass_matrix_parameter_derivative: Function | None = None
    rhs_parameter_jacobian: Function | None = None
    output_parameter_jacobian: Function | None = None
    force_jacobians_directional: Function | None = None
    mass_matrix_directional: Function | None = None
    mass_matrix_times_derivative_directional: Function | None = None
    output_jacobians_directional: Function | None = None
    loss_matrix_directional: Function | None = None

    @classmethod
    def of(cls, module: Any, path: str = "") -> GeneratedModel:
        """The model of ``module`` (checked by :func:`check_protocol`)."""
        check_protocol(module, path or None)

        def optional(name: str, default: Any) -> Any:
            value = getattr(module, name, None)
            return default if value is None else value

        def function(name: str) -> Function | None:
            fn = getattr(module, name, None)
            return fn if callable(fn) else None

        values = {name: getattr(module, name) for name in (*_CONSTANTS, *_FUNCTIONS)}
        return cls(
            module=module,
            path=path or str(getattr(module, "__file__", "") or ""),
            DESCRIPTION=optional("DESCRIPTION", ""),
            COORDINATE_UNITS=list(optional("COORDINATE_UNITS", ())),
            INPUT_UNITS=list(optional("INPUT_UNITS", ())),
            INPUT_RATES=dict(optional("INPUT_RATES", {})),
            OUTPUT_UNITS=list(optional("OUTPUT_UNITS", ())),
            ENERGY=list(optional("ENERGY", ())),
            LOSS_REFERENCE_FREQUENCY=optional("LOSS_REFERENCE_FREQUENCY", None),
            FRAMES=list(optional("FRAMES", ())),
            FRAME_PARENTS=list(optional("FRAME_PARENTS", ())),
            BODIES=list(optional("BODIES", ())),
            BACKEND=str(optional("BACKEND", "numpy")),
            BACKEND_NOTE=str(optional("BACKEND_NOTE", "")),
            BACKEND_ERROR=str(optional("BACKEND_ERROR", "")),
            PARAMETER_RANGES=dict(optional("PARAMETER_RANGES", {})),
            **values,
            **{name: function(name) for name in _OPTIONAL_FUNCTIONS},
        )

    def __repr__(self) -> str:
        return (f"GeneratedModel({self.MODEL_NAME!r}, {len(self.COORDINATES)} coordinates, "
                f"{len(self.CONSTRAINTS)} constraints, backend {self.BACKEND!r})")

    # ------------------------------------------------------------------ sizes and names
    @property
    def n(self) -> int:
        """Number of coordinates."""
        return len(self.COORDINATES)

    @property
    def state_names(self) -> list[str]:
        """Names of ``x = [y, ẏ]``: the coordinates and ``d_<coordinate>``."""
        return [*self.COORDINATES, *(f"d_{c}" for c in self.COORDINATES)]

    @property
    def first_order_state(self) -> bool:
        """Whether the state is ``[y, ẏ]`` only (``STATE_SIZE = 2n``)."""
        return int(self.STATE_SIZE) == 2 * self.n

    # ------------------------------------------------------------------ capabilities
    @property
    def has_constraints(self) -> bool:
        """Closed kinematic loops (``CONSTRAINTS``): simulated as a DAE."""
        return bool(self.CONSTRAINTS)

    @property
    def has_outputs(self) -> bool:
        return bool(self.OUTPUTS)

    @property
    def has_inputs(self) -> bool:
        return bool(self.INPUTS)

    @property
    def has_elastic_bodies(self) -> bool:
        """Elastic bodies (``BODIES`` of kind ``elastic``)."""
        return any(b.get("kind") == "elastic" for b in self.BODIES)

    @property
    def compiled(self) -> bool:
        """A compiled module that integrates itself (``integrate_dopri5``: ``c-dopri5``)."""
        return self.integrate_dopri5 is not None

    @property
    def separate_reactions(self) -> bool:
        """Constraint reactions with their own Jacobian ``G_R ≠ G`` (two-sided elastic node
        frames; ``constraint_reaction_jacobian``)."""
        return self.constraint_reaction_jacobian is not None

    @property
    def has_energy(self) -> bool:
        return self.energy is not None

    @property
    def has_loss_matrix(self) -> bool:
        """Loss factors: the hysteretic matrix ``G`` (``loss_matrix``)."""
        return self.loss_matrix is not None

    @property
    def has_poses(self) -> bool:
        """Frame poses of ``FRAMES`` for drawings (``frame_poses``)."""
        return self.frame_poses is not None

    @property
    def has_node_positions(self) -> bool:
        return self.node_positions is not None

    @property
    def has_parameter_derivatives(self) -> bool:
        """The first parameter derivatives (``rhs_parameter_jacobian`` …): in every module
        generated since they exist."""
        return None not in (self.default_inputs_parameter_jacobian, self.force_parameter_jacobian,
                            self.mass_matrix_parameter_derivative, self.rhs_parameter_jacobian,
                            self.output_parameter_jacobian)

    @property
    def has_directional_derivatives(self) -> bool:
        """The directional second derivatives of the linear models' sensitivities (rigid
        modules generated with sensitivities; ``loss_matrix_directional`` where there are
        loss factors)."""
        return None not in (self.force_jacobians_directional, self.mass_matrix_directional,
                            self.mass_matrix_times_derivative_directional,
                            self.output_jacobians_directional) and (
            self.loss_matrix is None or self.loss_matrix_directional is not None)


#: A generated model, a generated module (or any object with the protocol's names) or the
#: path of a generated ``.py`` file.
ModelLike = GeneratedModel | Any

_OPTIONAL_FUNCTIONS = ("constraint_reaction_jacobian", "constraint_time_derivative", "energy",
                       "loss_matrix", "frame_poses", "body_properties", "node_positions",
                       "integrate_dopri5", "generalized_alpha_steps",
                       "default_inputs_parameter_jacobian",
                       "force_parameter_jacobian", "mass_matrix_parameter_derivative",
                       "rhs_parameter_jacobian", "output_parameter_jacobian",
                       "force_jacobians_directional", "mass_matrix_directional",
                       "mass_matrix_times_derivative_directional",
                       "output_jacobians_directional", "loss_matrix_directional")


def as_model(module: ModelLike) -> GeneratedModel:
    """The :class:`GeneratedModel` of a model, a module or object with the protocol, or the
    path of a generated module (:func:`load_generated`).

    Raises
    ------
    NeweulError
        When the module does not implement the protocol (:func:`check_protocol`).
    """
    if isinstance(module, GeneratedModel):
        return module
    if isinstance(module, str | os.PathLike):
        return load_generated(module)
    return GeneratedModel.of(module)


def load_generated(path: str | os.PathLike[str]) -> GeneratedModel:
    """Import the generated module at ``path``, check its protocol and return its model.

    The module is imported under a private name derived from the file's content
    (``neweul_generated_<name>_<sha>``), so loading two different files with the same model name,
    or a regenerated file, never returns a stale module.

    Parameters
    ----------
    path
        A ``.py`` file written by ``neweul generate``.

    Returns
    -------
    GeneratedModel
        The module's constants and functions as attributes (``model.module`` is the imported
        module itself).

    Raises
    ------
    NeweulError
        If the file is missing, not a regular file, larger than :data:`MAX_MODULE_BYTES`,
        cannot be imported, or does not implement the protocol.

    Examples
    --------
    >>> mod = load_generated("generated/pendulum.py")  # doctest: +SKIP
    >>> mod.rhs(0.0, mod.INITIAL_STATE, mod.default_parameters())  # doctest: +SKIP
    """
    path = Path(path)
    raw = read_checked(path, "generated module", MAX_MODULE_BYTES, NeweulError)
    name = generated_module_name(path, raw)
    if name in sys.modules:
        module = sys.modules[name]
    else:
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise NeweulError(f"{path}: cannot be imported as a Python module")
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            raise NeweulError(
                f"{path}: importing the generated module failed: {type(exc).__name__}: {exc}"
            ) from None
        sys.modules[name] = module
    return GeneratedModel.of(module, str(path))
