"""What an FMU of a model declares: its variables, ``modelDescription.xml`` and ``model.h``.

An FMI 2.0 FMU (Functional Mock-up Interface for Model Exchange and Co-Simulation 2.0.5,
Modelica Association, 2024; docs/fmu-export.md) of a generated model exposes

* the parameters as tunable parameters with their defaults,
* the inputs (``INPUTS``, the rates ``d_<u>``, ``dd_<u>`` of kinematic excitations included)
  with their numeric defaults as start values,
* the coordinates ``y`` and velocities ``ẏ``; the *independent* ones are the continuous
  states (all of them without constraints), the dependent ones are calculated,
* the state derivatives ``der(y_i)``, ``der(d_y_i)``,
* the outputs (``OUTPUTS``),

with value references in this order, which the fixed C text ``fmi2/neweul_fmi2.c`` reads
through the macros of ``model.h`` (:func:`model_header`). Units are the SI units the model
knows (``COORDINATE_UNITS``, ``INPUT_UNITS``, ``OUTPUT_UNITS`` of the generated module,
:func:`.blocks.units`); descriptions say what each variable is.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..model import (
    ExpressionOutput,
    ForceOutput,
    KinematicOutput,
    System,
    as_expr,
    time,
)
from .c_templates import C_DOPRI5_TABLEAU, C_LU

__all__ = ["KINDS", "ElasticData", "FmuModel", "FmuVariable", "export_problems", "fmi_unit",
           "fmu_model", "model_description", "model_header"]

#: FMU kinds of ``neweul export --kind``: model exchange, co-simulation, or one FMU with both.
KINDS: dict[str, tuple[str, ...]] = {"me": ("me",), "cs": ("cs",), "both": ("me", "cs")}

#: Default relative (and absolute) tolerance of the co-simulation stepper when the importer
#: gives none in ``fmi2SetupExperiment`` (the ``DefaultExperiment`` of the FMU).
DEFAULT_TOLERANCE = 1e-6

#: Tolerance of Newton's method on the constraints (times ``1 + max |y|``), as the projection
#: of ``neweul simulate`` (analysis/dae.py).
NEWTON_TOLERANCE = 1e-13

#: SI base-unit exponents of the unit names used (``modelDescription.xml`` UnitDefinitions).
_BASE: dict[str, dict[str, int]] = {
    "m": {"m": 1}, "rad": {"rad": 1}, "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
}


@dataclass(frozen=True)
class FmuVariable:
    """One ScalarVariable of ``modelDescription.xml`` (FMI 2.0 §2.2.7).

    ``derivative``: the 1-based index of the state this variable is the derivative of.
    """

    name: str
    causality: str
    variability: str
    initial: str | None = None
    start: float | None = None
    unit: str = ""
    description: str = ""
    derivative: int | None = None


@dataclass(frozen=True)
class ElasticData:
    """The elastic bodies' arrays of an FMU, in ``resources/`` (docs/fmu-export.md).

    Attributes
    ----------
    name
        The file name in ``resources/``.
    content
        The arrays as little-endian float64, one after the other, in the order the model's
        ``nw_bind`` takes them.
    sizes
        The number of elements of each array.
    """

    name: str
    content: bytes
    sizes: tuple[int, ...]

    @property
    def checksums(self) -> tuple[int, int]:
        """``(Σ w_i, Σ (i + 1) w_i) mod 2⁶⁴`` of the 64-bit words ``w_i`` of ``content``
        (little-endian): the FMU refuses a file whose sums differ (a changed, shifted or
        swapped word changes them; an integrity check, not a signature)."""
        w = np.frombuffer(self.content, dtype="<u8").astype(np.uint64)
        i = np.arange(1, w.size + 1, dtype=np.uint64)
        with np.errstate(over="ignore"):
            return int(w.sum(dtype=np.uint64)), int((w * i).sum(dtype=np.uint64))


@dataclass(frozen=True)
class FmuModel:
    """The variables and constants of a model's FMU.

    Attributes
    ----------
    name
        The model's name (the FMU's ``modelIdentifier``).
    description
        The model's free text.
    parameters
        ``(name, default)`` in the order of ``p``.
    inputs, coordinates, velocities, outputs
        The variables of ``u``, ``y``, ``ẏ`` and the outputs, in the module's order.
    constraints
        The constraint names (empty without closed loops).
    dependent
        Indices of the dependent coordinates (one per constraint), the others are states.
    """

    name: str
    description: str
    parameters: tuple[tuple[str, float], ...]
    inputs: tuple[FmuVariable, ...]
    coordinates: tuple[FmuVariable, ...]
    velocities: tuple[FmuVariable, ...]
    outputs: tuple[FmuVariable, ...]
    constraints: tuple[str, ...] = ()
    dependent: tuple[int, ...] = ()

    @property
    def independent(self) -> tuple[int, ...]:
        """Indices of the coordinates that are continuous states."""
        dep = set(self.dependent)
        return tuple(j for j in range(len(self.coordinates)) if j not in dep)

    @property
    def derivatives(self) -> tuple[FmuVariable, ...]:
        """``der(y_i)``, ``der(d_y_i)`` of the independent coordinates, in state order
        ``[y_I, ẏ_I]``; ``derivative`` holds the 1-based index of the state."""
        nu, n = len(self.inputs), len(self.coordinates)
        first = len(self.parameters) + nu + 1        # index of y_0
        out = []
        for group, offset in ((self.coordinates, 0), (self.velocities, n)):
            for j in self.independent:
                v = group[j]
                out.append(FmuVariable(
                    f"der({v.name})", "local", "continuous", "calculated",
                    unit=_rate_unit(v.unit), derivative=first + offset + j,
                    description=f"time derivative of {v.name}"))
        return tuple(out)

    def variables(self) -> list[FmuVariable]:
        """All variables in value-reference order (the order of ``ModelVariables``)."""
        params = [FmuVariable(name, "parameter", "tunable", "exact", value,
                              description="parameter (tunable)")
                  for name, value in self.parameters]
        return [*params, *self.inputs, *self.coordinates, *self.velocities,
                *self.derivatives, *self.outputs]


def _rate_unit(unit: str) -> str:
    """``m`` → ``m/s`` → ``m/s2`` (``""`` stays)."""
    if not unit:
        return ""
    if unit.endswith("/s"):
        return unit + "2"
    if unit.endswith("/s2"):
        return ""
    return unit + "/s"


def _exponents(unit: str) -> dict[str, int]:
    """SI base-unit exponents of a unit name of :data:`_BASE` with ``/s``, ``/s2``."""
    base, _, per = unit.partition("/")
    exps = dict(_BASE[base])
    exps["s"] = exps.get("s", 0) - {"": 0, "s": 1, "s2": 2}[per]
    return {k: v for k, v in exps.items() if v}


def export_problems(system: System) -> list[tuple[str, str]]:
    """What keeps a model from being exported as an FMU, as ``(key path, message)`` pairs.

    * an input whose default is not a number (or an expression of parameters): an FMU's
      inputs are driven by the importer from a start value, so a default excitation in time
      (``F0*sin(Omega*t)``, a table) would be lost without a word.
    """
    problems: list[tuple[str, str]] = []
    params = {p.symbol for p in system.parameters}
    for i in system.inputs:
        default = as_expr(i.default)
        if not default.free_symbols <= params or time in default.free_symbols:
            problems.append((
                f"inputs.{i.name}",
                f"input {i.name!r} has no numeric default (its default excitation is {default}): "
                "an FMU's inputs start from a number and are driven by the importer; give it a "
                f"constant default (inputs: {{{i.name}: 0}}) and drive it in the importing tool"))
    return problems


def _output_descriptions(system: System) -> dict[str, str]:
    """``name → description`` of the description's outputs."""
    out = {}
    for o in system.outputs:
        if isinstance(o, KinematicOutput):
            point = ", ".join(str(c) for c in o.point)
            out[o.name] = (f"{o.quantity} of the point [{point}] of frame {o.frame}, "
                           f"{o.component} component in {o.in_frame}")
        elif isinstance(o, ExpressionOutput):
            out[o.name] = f"expression {o.expr}"
        elif isinstance(o, ForceOutput):
            out[o.name] = f"{o.component} of the force element {o.force}"
    return out


def fmi_unit(unit: str) -> str:
    """A unit of the generated module as an FMI unit name (``N m`` → ``N.m``, ``m/s²`` →
    ``m/s2``); ``""`` for units :data:`_BASE` does not know."""
    name = unit.replace(" ", ".").replace("²", "2")
    base, _, per = name.partition("/")
    return name if base in _BASE and per in ("", "s", "s2") else ""


def fmu_model(system: System, constants: Mapping[str, object], x0: Sequence[float],
              input_start: Sequence[float], dependent: Sequence[int] = ()) -> FmuModel:
    """The FMU's variables of a model.

    Parameters
    ----------
    system
        The model (the descriptions of its outputs).
    constants
        The generated module's protocol constants (``MODEL_NAME``, ``DESCRIPTION``,
        ``PARAMETERS``, ``INPUTS``, ``INPUT_RATES``, ``INPUT_UNITS``, ``COORDINATES``,
        ``COORDINATE_UNITS``,
        ``OUTPUTS``, ``OUTPUT_UNITS``, ``CONSTRAINTS``).
    x0
        The start state ``[y, ẏ]`` (consistent with the constraints).
    input_start
        The start values of ``INPUTS`` (the numeric defaults and zero rates).
    dependent
        Indices of the dependent coordinates (one per constraint).
    """
    names = list(constants["COORDINATES"])
    n = len(names)
    cunits = list(constants.get("COORDINATE_UNITS") or [""] * n)
    dep = set(dependent)
    rates = {r: (base, k + 1) for base, rs in dict(constants.get("INPUT_RATES") or {}).items()
             for k, r in enumerate(rs)}
    iunits = list(constants.get("INPUT_UNITS") or [""] * len(constants["INPUTS"]))
    inputs = []
    for name, start, unit in zip(constants["INPUTS"], input_start, iunits, strict=True):
        if name in rates:
            base, order = rates[name]
            what = ("time derivative" if order == 1 else "second time derivative")
            text = f"{what} of the input {base} (kinematic excitation; keep it consistent)"
        else:
            text = "input"
        inputs.append(FmuVariable(name, "input", "continuous", None, float(start),
                                  fmi_unit(unit), text))
    coords, vels = [], []
    constraints = ", ".join(constants.get("CONSTRAINTS") or [])
    for j, name in enumerate(names):
        state = j not in dep
        role = ("generalized coordinate" if state else
                f"generalized coordinate, dependent (from the constraints {constraints})")
        initial, start = ("exact", float(x0[j])) if state else ("calculated", None)
        coords.append(FmuVariable(name, "local", "continuous", initial, start,
                                  fmi_unit(cunits[j]), role))
        vstart = float(x0[n + j]) if state else None
        vels.append(FmuVariable(f"d_{name}", "local", "continuous", initial, vstart,
                                _rate_unit(fmi_unit(cunits[j])), f"time derivative of {name}"))
    descr = _output_descriptions(system)
    ounits = list(constants.get("OUTPUT_UNITS") or [""] * len(constants["OUTPUTS"]))
    outputs = []
    for name, unit in zip(constants["OUTPUTS"], ounits, strict=True):
        outputs.append(FmuVariable(name, "output", "continuous", "calculated", None,
                                   fmi_unit(unit), descr.get(name, "output")))
    params = tuple((str(k), float(v)) for k, v in dict(constants["PARAMETERS"]).items())
    return FmuModel(
        name=str(constants["MODEL_NAME"]), description=str(constants.get("DESCRIPTION", "")),
        parameters=params, inputs=tuple(inputs), coordinates=tuple(coords),
        velocities=tuple(vels), outputs=tuple(outputs),
        constraints=tuple(constants.get("CONSTRAINTS") or ()), dependent=tuple(dependent))


def _number(v: float) -> str:
    """A float as XML/C text that reads back to the same double."""
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {v!r}")
    return repr(float(v))


def model_description(model: FmuModel, guid: str, kinds: Sequence[str],
                      source_files: Sequence[str], tool: str) -> str:
    """The text of ``modelDescription.xml`` (FMI 2.0 §2.2, §3.3, §4.3): deterministic."""
    variables = model.variables()
    jacobian = "false" if model.constraints else "true"
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model.name, "guid": guid,
        "description": " ".join(model.description.split()), "generationTool": tool,
        "variableNamingConvention": "flat", "numberOfEventIndicators": "0"})
    common = {"modelIdentifier": model.name, "needsExecutionTool": "false",
              "canBeInstantiatedOnlyOncePerProcess": "false",
              "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "false",
              "canSerializeFMUstate": "false", "providesDirectionalDerivative": jacobian}
    for kind in ("me", "cs"):
        if kind not in kinds:
            continue
        if kind == "me":
            el = ET.SubElement(root, "ModelExchange", {
                **common, "completedIntegratorStepNotNeeded": "true"})
        else:
            el = ET.SubElement(root, "CoSimulation", {
                **common, "canHandleVariableCommunicationStepSize": "true",
                "canInterpolateInputs": "true", "maxOutputDerivativeOrder": "0",
                "canRunAsynchronuously": "false"})
        files = ET.SubElement(el, "SourceFiles")
        for f in source_files:
            ET.SubElement(files, "File", {"name": f})
    units = sorted({v.unit for v in variables if v.unit})
    if units:
        defs = ET.SubElement(root, "UnitDefinitions")
        for u in units:
            ET.SubElement(ET.SubElement(defs, "Unit", {"name": u}), "BaseUnit",
                          {k: str(e) for k, e in sorted(_exponents(u).items())})
    cats = ET.SubElement(root, "LogCategories")
    ET.SubElement(cats, "Category", {"name": "logStatusError",
                                     "description": "errors of the model's evaluation"})
    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0",
                                              "tolerance": _number(DEFAULT_TOLERANCE)})
    mv = ET.SubElement(root, "ModelVariables")
    for vr, v in enumerate(variables):
        attrs = {"name": v.name, "valueReference": str(vr)}
        if v.description:
            attrs["description"] = v.description
        attrs["causality"] = v.causality
        attrs["variability"] = v.variability
        if v.initial is not None and v.causality != "parameter":
            attrs["initial"] = v.initial
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        real: dict[str, str] = {}
        if v.unit:
            real["unit"] = v.unit
        if v.start is not None:
            real["start"] = _number(v.start)
        if v.derivative is not None:
            real["derivative"] = str(v.derivative)
        ET.SubElement(sv, "Real", real)
    ms = ET.SubElement(root, "ModelStructure")
    index = {id(v): k + 1 for k, v in enumerate(variables)}
    outputs = [index[id(v)] for v in variables if v.causality == "output"]
    derivs = [index[id(v)] for v in variables if v.derivative is not None]
    for tag, indices in (("Outputs", outputs), ("Derivatives", derivs),
                         ("InitialUnknowns", sorted(outputs + derivs))):
        if indices:
            el = ET.SubElement(ms, tag)
            for k in indices:
                ET.SubElement(el, "Unknown", {"index": str(k)})
    ET.indent(root, space="  ")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")


def _c_array(ctype: str, name: str, size: str, values: Sequence[float | int]) -> str:
    items = [str(int(v)) if ctype == "int" else _number(float(v)) for v in values] or ["0"]
    return f"static const {ctype} {name}[{size}] = {{{', '.join(items)}}};"


def _c_string(text: str) -> str:
    safe = "".join(c if 32 <= ord(c) < 127 and c not in '"\\' else "?" for c in text)
    return f'"{safe}"'


def model_header(model: FmuModel, guid: str, kinds: Sequence[str],
                 data: ElasticData | None = None) -> str:
    """The text of ``model.h``: sizes, value-reference offsets, start values and partition of
    the model, the elastic bodies' data file (``data``: its name in ``resources/``, the sizes
    of its arrays, its checksums), the dense LU and the Dormand–Prince tableau
    (``c_templates``)."""
    n, nu, ny = len(model.coordinates), len(model.inputs), len(model.outputs)
    npar, nc, ni = len(model.parameters), len(model.constraints), len(model.independent)
    x0 = [v.start if v.start is not None else 0.0 for v in (*model.coordinates,
                                                             *model.velocities)]
    u0 = [v.start or 0.0 for v in model.inputs]
    vr_u = npar
    vr_y = vr_u + nu
    vr_der = vr_y + 2 * n
    vr_out = vr_der + 2 * ni
    dep_names = ", ".join(model.coordinates[j].name for j in model.dependent)
    lines = [
        f"/* The model {model.name!r} for its FMU: generated by neweul-py, do not edit. */",
        f"#define NW_GUID {_c_string(guid)}",
        f"#define NW_N {n}", f"#define NW_NP {npar}", f"#define NW_NU {nu}",
        f"#define NW_NY {ny}", f"#define NW_NC {nc}", f"#define NW_NI {ni}",
        f"#define NW_MODEL_EXCHANGE {int('me' in kinds)}",
        f"#define NW_CO_SIMULATION {int('cs' in kinds)}",
        f"#define NW_TOLERANCE {_number(DEFAULT_TOLERANCE)}",
        f"#define NW_NEWTON_TOL {_number(NEWTON_TOLERANCE)}",
        f"#define NW_CONSTRAINT_NAMES {_c_string(', '.join(model.constraints))}",
        f"#define NW_DEPENDENT_NAMES {_c_string(dep_names)}",
        "#define NW_VR_P 0", f"#define NW_VR_U {vr_u}", f"#define NW_VR_Y {vr_y}",
        f"#define NW_VR_DER {vr_der}", f"#define NW_VR_OUT {vr_out}",
        f"#define NW_NVR {vr_out + ny}",
        _c_array("double", "nw_p0", "NW_NP + 1", [v for _, v in model.parameters]),
        _c_array("double", "nw_u0", "NW_NU + 1", u0),
        _c_array("double", "nw_x0", "2 * NW_N", x0),
        _c_array("int", "nw_indep", "NW_NI + 1", model.independent),
        _c_array("int", "nw_dep", "NW_NC + 1", model.dependent),
        f"#define NW_DATA_COUNT {0 if data is None else len(data.sizes)}",
    ]
    if data is not None:
        lines += [f"#define NW_DATA_FILE {_c_string(data.name)}",
                  f"#define NW_DATA_SUM {data.checksums[0]:#018x}ULL",
                  f"#define NW_DATA_WSUM {data.checksums[1]:#018x}ULL",
                  f"static const long nw_data_sizes[NW_DATA_COUNT] = "
                  f"{{{', '.join(str(int(k)) for k in data.sizes)}}};"]
    return "\n".join(lines) + "\n" + C_LU + C_DOPRI5_TABLEAU
