"""Reader and writer of SID files (standard input data of flexible bodies).

The SID text format (Wallrapp 1994, "Standardization of flexible body modeling in multibody
system codes, Part I"; Schwertassek & Wallrapp 1999, ch. 6) is a nest of
blocks::

    <free header line(s)>
    part
      new modal =
        refmod  mass = …, nelastq = …, ielastq(i) = <mode name>  end refmod
        frame
          new node = <id>
            rframe = <name>
            origin / phi / psi / AP      (Taylor objects)
          end node
          …
        end frame
        mdCM, J, Ct, Cr, Me, Gr, Ge, Oe, ksigma, Ke, De   (Taylor objects)
      end modal
    end part

A Taylor object has the header ``order, nrow, ncol, nq, nqn, structure`` followed by the
nonzero entries ``m0(i, j) = v`` and ``m1(i, k, j) = v`` (row, mode, column; 1-based;
Fortran ``D`` exponents allowed); see :mod:`neweul_py.elastic.bodies.taylor`.

Conventions of the format, as used by the SID exporters and consumers (e.g. the PY_SID
exporter and EMBS_ModelicaLib) and checked against the beam file in ``tests/data``:

* ``J`` is stored either as a 6×1 column ``[Jxx, Jyy, Jzz, Jxy, Jxz, Jyz]`` or as a symmetric
  3×3 matrix; :attr:`SIDBody.J` always returns the 3×3 form.
* ``Gr`` (3×3nq) and ``Ge`` (nq×3nq) hold the blocks ``G_k`` (multiplied by ``q̇_k`` and then
  by ``ω``) either per mode (``[G_1 | … | G_nq]``) or per ω component (``[G^x | G^y | G^z]``):
  exporters differ, and :class:`SIDBody` keeps the file's arrays as they are;
  :func:`invariants_from_sid` recognizes the layout.
* ``Oe`` columns are ``ωx², ωy², ωz², ωxωy, ωyωz, ωxωz``.

The reader is a line tokenizer plus a block parser that keeps line numbers: a syntax error,
an unclosed block or inconsistent sizes raise :class:`~neweul_py.errors.DataError` naming
the file, the block path (``part.modal.frame.node[1861].origin``) and the line.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ...atomic import atomic_write
from ...errors import DataError
from ...files import read_checked
from ..bodies.invariants import Invariants, NodeFrame
from ..bodies.taylor import Taylor

__all__ = ["INVARIANT_NAMES", "SIDBody", "SIDNode", "invariants_from_sid", "invariants_to_sid",
           "read_sid", "write_sid"]

#: The body-level Taylor objects of a SID ``modal`` block, in file order.
INVARIANT_NAMES = ("mdCM", "J", "Ct", "Cr", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De")
#: Index order of the 6×1 form of ``J``.
J6_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
_NODE_TAYLORS = ("origin", "phi", "psi", "AP")
_HEADER_KEYS = ("order", "nrow", "ncol", "nq", "nqn", "structure")


# --------------------------------------------------------------------------- data model
@dataclass(frozen=True, eq=False)
class SIDNode:
    """One ``new node`` block: a node frame of the flexible body.

    Parameters
    ----------
    id
        Node id (the value of ``new node = …``).
    rframe
        Name of the frame the data refer to (``"body ref"``).
    origin
        Taylor 3×1: node position ``origin(q) = x⁰ + Φ q``.
    phi, psi
        Taylor 3×nq: translational and rotational mode shapes at the node.
    AP
        Taylor 3×3: node-frame orientation ``AP(q) = AP⁰ + Σ ψ̃_k q_k`` (first order).
    extra
        Any further Taylor objects of the node block (e.g. ``sigma``), kept for writing.
    """

    id: int
    rframe: str
    origin: Taylor
    phi: Taylor
    psi: Taylor
    AP: Taylor
    extra: Mapping[str, Taylor] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class SIDBody:
    """The content of a SID file (one modal body).

    Parameters
    ----------
    mass
        ``refmod.mass``.
    ielastq
        Names of the elastic coordinates (``refmod.ielastq``), one per mode.
    nodes
        The node frames, in file order.
    taylors
        Body-level Taylor objects by name (:data:`INVARIANT_NAMES` and any others), in file
        order, as stored in the file (``J`` may be 6×1).
    header
        Free text before ``part`` (written back as is).
    source
        The file it was read from, if any.
    """

    mass: float
    ielastq: tuple[str, ...]
    nodes: tuple[SIDNode, ...]
    taylors: Mapping[str, Taylor]
    header: str = ""
    source: str | None = None

    @property
    def nq(self) -> int:
        """Number of elastic coordinates (``refmod.nelastq``)."""
        return len(self.ielastq)

    @property
    def nelastq(self) -> int:
        """``refmod.nelastq`` (same as :attr:`nq`)."""
        return len(self.ielastq)

    def __getitem__(self, name: str) -> Taylor:
        return self.taylors[name]

    def get(self, name: str) -> Taylor | None:
        """The Taylor object ``name`` or ``None`` when the file has none."""
        return self.taylors.get(name)

    @property
    def J(self) -> Taylor:
        """The inertia tensor about the body-frame origin as a 3×3 Taylor object."""
        return j_as_matrix(self.taylors["J"])

    def node(self, node_id: int) -> SIDNode:
        """The node frame with id ``node_id``."""
        for n in self.nodes:
            if n.id == node_id:
                return n
        raise DataError(f"no node {node_id} (nodes: {[n.id for n in self.nodes]})",
                        self.source, "frame")

    def frequencies_from_names(self) -> np.ndarray | None:
        """The frequencies (Hz) printed in the ``ielastq`` names (``… : 51.626 Hz``), or
        ``None`` if not every name carries one."""
        out = []
        for name in self.ielastq:
            m = re.search(r"([-+]?\d+(?:\.\d*)?(?:[eEdD][-+]?\d+)?)\s*Hz", name)
            if m is None:
                return None
            out.append(float(m.group(1).replace("D", "E").replace("d", "e")))
        return np.array(out)


def j_as_matrix(J: Taylor) -> Taylor:
    """``J`` as a 3×3 Taylor object (from the 6×1 ``[xx, yy, zz, xy, xz, yz]`` form)."""
    if (J.nrow, J.ncol) == (3, 3):
        return J
    if (J.nrow, J.ncol) != (6, 1):
        raise DataError(f"J must be 6×1 or 3×3, got {J.nrow}×{J.ncol}", item="J")
    rows = np.array([a for a, _ in J6_INDEX])
    cols = np.array([b for _, b in J6_INDEX])
    m0 = np.zeros((3, 3))
    m0[rows, cols] = J.m0[:, 0]
    m0[cols, rows] = J.m0[:, 0]
    m1 = None
    if J.m1 is not None:
        m1 = np.zeros((3, J.nq, 3))
        m1[rows, :, cols] = J.m1[:, :, 0]
        m1[cols, :, rows] = J.m1[:, :, 0]
    return Taylor.from_arrays(m0, m1, nq=J.nq)


def j_as_column(J: Taylor) -> Taylor:
    """``J`` in the 6×1 SID form ``[xx, yy, zz, xy, xz, yz]`` (from 3×3)."""
    if (J.nrow, J.ncol) == (6, 1):
        return J
    rows = np.array([a for a, _ in J6_INDEX])
    cols = np.array([b for _, b in J6_INDEX])
    m0 = J.m0[rows, cols][:, None]
    m1 = None if J.m1 is None else J.m1[rows, :, cols][:, :, None]
    return Taylor.from_arrays(m0, m1, nq=J.nq)


# ------------------------------------------------------------------------- tokenizer
_RE_END = re.compile(r"^end\s+(\w+)$", re.IGNORECASE)
_RE_NEW = re.compile(r"^new\s+(\w+)\s*(?:=\s*(.*))?$", re.IGNORECASE)
_RE_ASSIGN = re.compile(r"^(\w+)\s*(?:\(([^()]*)\))?\s*=\s*(.*)$")
_RE_OPEN = re.compile(r"^(\w+)$")


@dataclass
class _Assign:
    line: int
    key: str
    index: tuple[int, ...] | None
    value: str


@dataclass
class _Block:
    line: int
    name: str
    value: str | None = None
    children: list = field(default_factory=list)
    end_line: int | None = None


def _tokenize(text: str, file: str | None) -> tuple[str, _Block]:
    """Split the header off and build the block tree, checking the nesting."""
    lines = text.splitlines()
    start = None
    for no, raw in enumerate(lines, 1):
        if raw.strip().lower() == "part":
            start = no
            break
    if start is None:
        raise DataError("no 'part' block found", file, "part", 1 if lines else None)
    header = "\n".join(lines[: start - 1])
    root = _Block(start, "part")
    stack = [root]
    path = lambda: ".".join(b.name for b in stack)  # noqa: E731
    for no in range(start + 1, len(lines) + 1):
        s = lines[no - 1].strip()
        if not s:
            continue
        if not stack:
            raise DataError(f"text after 'end part': {s!r}", file, "part", no)
        if m := _RE_END.fullmatch(s):
            name = m.group(1)
            top = stack[-1]
            if name.lower() != top.name.lower():
                raise DataError(
                    f"'end {name}' does not close block '{top.name}' opened at line "
                    f"{top.line} (missing 'end {top.name}'?)", file, path(), no)
            top.end_line = no
            stack.pop()
            continue
        if m := _RE_NEW.fullmatch(s):
            blk = _Block(no, m.group(1), (m.group(2) or "").strip())
            stack[-1].children.append(blk)
            stack.append(blk)
            continue
        if m := _RE_ASSIGN.fullmatch(s):
            idx = None
            if m.group(2) is not None:
                try:
                    idx = tuple(int(t) for t in m.group(2).split(","))
                except ValueError:
                    raise DataError(f"bad index {m.group(2)!r} in {s!r}", file, path(),
                                    no) from None
            stack[-1].children.append(_Assign(no, m.group(1), idx, m.group(3).strip()))
            continue
        if m := _RE_OPEN.fullmatch(s):
            blk = _Block(no, m.group(1))
            stack[-1].children.append(blk)
            stack.append(blk)
            continue
        raise DataError(f"syntax error: cannot read {s!r}", file, path(), no)
    if stack:
        top = stack[-1]
        raise DataError(f"end of file inside block '{top.name}' opened at line {top.line} "
                        f"(missing 'end {top.name}')", file, path(), len(lines))
    return header, root


def _float(a: _Assign, file: str | None, item: str) -> float:
    try:
        value = float(a.value.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise DataError(f"{a.key} = {a.value!r} is not a number", file, item, a.line) from None
    if not math.isfinite(value):
        raise DataError(f"{a.key} = {a.value!r} is not a finite number", file, item, a.line)
    return value


def _int(a: _Assign, file: str | None, item: str) -> int:
    try:
        return int(a.value)
    except ValueError:
        raise DataError(f"{a.key} = {a.value!r} is not an integer", file, item,
                        a.line) from None


# ---------------------------------------------------------------------------- parser
def _parse_taylor(blk: _Block, file: str | None, item: str,
                  expect: tuple[int | tuple[int, ...], int | tuple[int, ...]] | None,
                  nq: int) -> Taylor:
    head: dict[str, tuple[int, int]] = {}
    m0e: list[tuple[int, int, float]] = []
    m1e: list[tuple[int, int, int, float]] = []
    entries: list[_Assign] = []
    for c in blk.children:
        if isinstance(c, _Block):
            raise DataError(f"unexpected block '{c.name}' inside Taylor object", file,
                            f"{item}.{c.name}", c.line)
        key = c.key.lower()
        if key in _HEADER_KEYS and c.index is None:
            if key in head:
                raise DataError(f"'{c.key}' given twice", file, item, c.line)
            head[key] = (_int(c, file, item), c.line)
        elif key in ("m0", "m1"):
            entries.append(c)
        else:
            raise DataError(f"unknown entry '{c.key}' in a Taylor object", file, item, c.line)
    head.setdefault("nqn", (0, blk.line))
    for key in _HEADER_KEYS:
        if key not in head:
            raise DataError(f"Taylor object without '{key}'", file, item, blk.line)
    order, nrow, ncol, nqh, nqn, structure = (head[k][0] for k in _HEADER_KEYS)
    if order not in (0, 1):
        raise DataError(f"order {order} not supported (0 or 1)", file, item, head["order"][1])
    if nqn != 0:
        raise DataError(f"higher-order terms (nqn = {nqn}) not supported", file, item,
                        head["nqn"][1])
    if structure not in (0, 1, 2, 3, 4):
        raise DataError(f"unknown structure {structure} (0…4)", file, item,
                        head["structure"][1])
    if structure in (1, 2, 4) and nrow != ncol:
        raise DataError(f"structure {structure} needs a square matrix, got {nrow}×{ncol}",
                        file, item, head["structure"][1])
    if expect is not None:
        for key, want in zip(("nrow", "ncol"), expect, strict=True):
            wants = want if isinstance(want, tuple) else (want,)
            if head[key][0] not in wants:
                raise DataError(
                    f"{key} = {head[key][0]}, expected {' or '.join(map(str, wants))} "
                    f"(nelastq = {nq})", file, item, head[key][1])
        if isinstance(expect[0], tuple):  # J: 6×1 or 3×3
            if (nrow, ncol) not in ((6, 1), (3, 3)):
                raise DataError(f"J must be 6×1 or 3×3, got {nrow}×{ncol}", file, item,
                                head["nrow"][1])
    if order == 1 and nqh != nq:
        raise DataError(f"nq = {nqh} but nelastq = {nq}", file, item, head["nq"][1])
    if order == 0 and nqh not in (0, nq):  # order 0: nelastq, or 0 (no q-dependence)
        raise DataError(f"nq = {nqh} but nelastq = {nq} (an order-0 object has nq = "
                        f"nelastq or 0)", file, item, head["nq"][1])
    seen: set[tuple[int, ...]] = set()
    for c in entries:
        key = c.key.lower()
        dims = (nrow, ncol) if key == "m0" else (nrow, nqh, ncol)
        if c.index is None or len(c.index) != len(dims):
            raise DataError(f"'{c.key}' needs {len(dims)} indices", file, item, c.line)
        if key == "m1" and order == 0:
            raise DataError("m1 entry in an order-0 Taylor object", file, item, c.line)
        if any(not 1 <= i <= d for i, d in zip(c.index, dims, strict=True)):
            raise DataError(f"{c.key}{c.index} outside the size {dims}", file, item, c.line)
        if structure in (0, 4):
            raise DataError(f"structure {structure} lists no entries, found {c.key}{c.index}",
                            file, item, c.line)
        i, j = c.index[0], c.index[-1]
        if structure == 1 and i != j:
            raise DataError(f"off-diagonal entry {c.key}{c.index} with structure 1",
                            file, item, c.line)
        if (key, *c.index) in seen:
            raise DataError(f"{c.key}{c.index} given twice", file, item, c.line)
        seen.add((key, *c.index))
        v = _float(c, file, item)
        if key == "m0":
            m0e.append((c.index[0], c.index[1], v))
        else:
            m1e.append((c.index[0], c.index[1], c.index[2], v))
    try:
        return Taylor.from_entries(order, nrow, ncol, nqh, nqn, structure, m0e, m1e)
    except DataError as exc:
        raise DataError(exc.message, file, item, blk.line) from None


def _expected(name: str, nq: int) -> tuple | None:
    return {
        "mdCM": (3, 1), "J": ((6, 3), (1, 3)), "Ct": (nq, 3), "Cr": (nq, 3),
        "Me": (nq, nq), "Gr": (3, 3 * nq), "Ge": (nq, 3 * nq), "Oe": (nq, 6),
        "ksigma": (nq, 1), "Ke": (nq, nq), "De": (nq, nq),
        "origin": (3, 1), "phi": (3, nq), "psi": (3, nq), "AP": (3, 3),
    }.get(name)


def _canonical(name: str, names: tuple[str, ...]) -> str:
    for n in names:
        if n.lower() == name.lower():
            return n
    return name


def _parse_refmod(blk: _Block, file: str | None) -> tuple[float, tuple[str, ...]]:
    item = "part.modal.refmod"
    mass = nel = None
    names: dict[int, str] = {}
    for c in blk.children:
        if isinstance(c, _Block):
            raise DataError(f"unexpected block '{c.name}' in refmod", file, item, c.line)
        key = c.key.lower()
        if key == "mass":
            mass = _float(c, file, item)
        elif key == "nelastq":
            nel = (_int(c, file, item), c.line)
        elif key == "ielastq":
            if c.index is None or len(c.index) != 1:
                raise DataError("ielastq needs one index", file, item, c.line)
            names[c.index[0]] = c.value
        else:
            raise DataError(f"unknown refmod entry '{c.key}'", file, item, c.line)
    if mass is None:
        raise DataError("refmod without 'mass'", file, item, blk.line)
    if mass <= 0:  # as a description refuses a negative mass (model/system.py)
        raise DataError(f"mass must be positive, got {mass:g}", file, f"{item}.mass", blk.line)
    if nel is None:
        raise DataError("refmod without 'nelastq'", file, item, blk.line)
    nq, line = nel
    bad = sorted(i for i in names if not 1 <= i <= nq)
    if bad:
        raise DataError(f"ielastq({bad[0]}) outside 1…nelastq = {nq}", file, item, line)
    if names and len(names) != nq:
        raise DataError(f"nelastq = {nq} but {len(names)} ielastq names", file, item, line)
    return mass, tuple(names.get(i, f"mode {i}") for i in range(1, nq + 1))


def _parse_node(blk: _Block, file: str | None, nq: int) -> SIDNode:
    try:
        node_id = int(blk.value or "")
    except ValueError:
        raise DataError(f"node id {blk.value!r} is not an integer", file,
                        "part.modal.frame.node", blk.line) from None
    item = f"part.modal.frame.node[{node_id}]"
    rframe = ""
    taylors: dict[str, Taylor] = {}
    for c in blk.children:
        if isinstance(c, _Assign):
            if c.key.lower() != "rframe":
                raise DataError(f"unknown node entry '{c.key}'", file, item, c.line)
            rframe = c.value
            continue
        name = _canonical(c.name, _NODE_TAYLORS)
        if name in taylors:
            raise DataError(f"'{name}' given twice", file, f"{item}.{name}", c.line)
        taylors[name] = _parse_taylor(c, file, f"{item}.{name}", _expected(name, nq), nq)
    for name in ("origin", "phi"):
        if name not in taylors:
            raise DataError(f"node without '{name}'", file, item, blk.line)
    psi = taylors.pop("psi", Taylor(0, 3, nq, nq, 0, 0, np.zeros((3, nq))))
    ap = taylors.pop("AP", Taylor(0, 3, 3, nq, 0, 4, np.eye(3)))
    return SIDNode(node_id, rframe, taylors.pop("origin"), taylors.pop("phi"), psi, ap,
                   taylors)


def read_sid(path: str | os.PathLike) -> SIDBody:
    """Read a SID file.

    Parameters
    ----------
    path
        The ``.SID_FEM`` (or similar) text file.

    Returns
    -------
    SIDBody
        The body with its node frames and Taylor objects.

    Raises
    ------
    DataError
        Naming the file, the block path and the line: syntax errors, unclosed blocks,
        sizes inconsistent with ``nelastq`` (or with the header line's node/mode counts),
        entries out of range or contradicting the ``structure`` flag, missing blocks.

    References
    ----------
    Wallrapp 1994; Schwertassek & Wallrapp 1999, ch. 6. ``docs/equations.md`` §2.

    Examples
    --------
    >>> body = read_sid("tests/data/beam.SID_FEM")     # doctest: +SKIP
    >>> body.nq, len(body.nodes)                       # doctest: +SKIP
    (11, 6)
    """
    file = os.fspath(path)
    text = read_checked(file, "SID file").decode("utf-8", errors="replace")
    header, root = _tokenize(text, file)
    modal = [c for c in root.children if isinstance(c, _Block)]
    stray = [c for c in root.children if isinstance(c, _Assign)]
    if stray:
        raise DataError(f"unexpected entry '{stray[0].key}' in part", file, "part",
                        stray[0].line)
    if len(modal) != 1 or modal[0].name.lower() != "modal":
        line = modal[1].line if len(modal) > 1 else root.line
        raise DataError("part must hold exactly one 'new modal' block", file, "part", line)
    modal = modal[0]
    refmods = [c for c in modal.children if isinstance(c, _Block) and
               c.name.lower() == "refmod"]
    if not refmods:
        raise DataError("modal block without 'refmod'", file, "part.modal", modal.line)
    mass, names = _parse_refmod(refmods[0], file)
    nq = len(names)
    nodes: list[SIDNode] = []
    taylors: dict[str, Taylor] = {}
    for c in modal.children:
        if isinstance(c, _Assign):
            raise DataError(f"unexpected entry '{c.key}' in modal", file, "part.modal", c.line)
        lname = c.name.lower()
        if lname == "refmod":
            if c is not refmods[0]:
                raise DataError("second 'refmod'", file, "part.modal.refmod", c.line)
            continue
        if lname == "frame":
            if nodes:
                raise DataError("second 'frame'", file, "part.modal.frame", c.line)
            for n in c.children:
                if not (isinstance(n, _Block) and n.name.lower() == "node"):
                    what = n.key if isinstance(n, _Assign) else n.name
                    raise DataError(f"'{what}' in frame (expected 'new node')", file,
                                    "part.modal.frame", n.line)
                nodes.append(_parse_node(n, file, nq))
            ids = [n.id for n in nodes]
            if len(set(ids)) != len(ids):
                raise DataError("duplicate node ids", file, "part.modal.frame", c.line)
            continue
        name = _canonical(c.name, INVARIANT_NAMES)
        item = f"part.modal.{name}"
        if name in taylors:
            raise DataError(f"'{name}' given twice", file, item, c.line)
        taylors[name] = _parse_taylor(c, file, item, _expected(name, nq), nq)
    for name in ("Me", "Ke"):
        if name not in taylors:
            raise DataError(f"modal block without '{name}'", file, "part.modal", modal.line)
    m = re.match(r"^\s*(\d+)\s+(\d+)\b", header.splitlines()[0]) if header else None
    if m is not None:
        nn, nm = int(m.group(1)), int(m.group(2))
        if (nn, nm) != (len(nodes), nq):
            raise DataError(f"header announces {nn} nodes and {nm} modes, the file has "
                            f"{len(nodes)} nodes and nelastq = {nq}", file, "header", 1)
    return SIDBody(mass, names, tuple(nodes), taylors, header, file)


# ---------------------------------------------------------------------------- writer
_EQ_COL = 48


def _fmt_float(v: float, digits: int = 12) -> str:
    return f"{v: .{digits - 1}E}".replace("E", "D")


def _kv(indent: int, key: str, value: str) -> str:
    return f"{' ' * indent}{key}".ljust(_EQ_COL) + "=" + value


def _write_taylor(out: list[str], indent: int, name: str, t: Taylor, digits: int) -> None:
    out.append(" " * indent + name)
    for key in _HEADER_KEYS:
        out.append(_kv(26, key, f"{getattr(t, key):5d}"))
    e0, e1 = t.entries()
    out.extend(_kv(26, f"m0( {i}, {j})", _fmt_float(v, digits)) for i, j, v in e0)
    out.extend(_kv(26, f"m1( {i}, {k}, {j})", _fmt_float(v, digits)) for i, k, j, v in e1)
    out.append(" " * indent + f"end {name}")


def write_sid(body: SIDBody | object, path: str | os.PathLike, *, digits: int = 12) -> None:
    """Write a one-sided body as a SID file (atomically: temp file + rename).

    Parameters
    ----------
    body
        A :class:`SIDBody`, or one-sided :class:`~neweul_py.elastic.bodies.invariants.Invariants`
        (:func:`invariants_to_sid`; two-sided ones refuse, the SID format holds one basis
        only).
    path
        Target file.
    digits
        Significant digits of the numbers (12, the common layout; 17 is lossless).

    Notes
    -----
    Values are printed in Fortran ``D`` notation, only nonzero entries (and, for structure 2,
    the lower triangle) are listed — the layout of common SID exporters. A file read with
    :func:`read_sid` and written back reads back identically when its numbers have at most
    ``digits`` significant digits (as files written with 12 digits do).
    """
    if not 1 <= digits <= 17:
        raise DataError(f"digits must be 1…17, got {digits}", os.fspath(path))
    if isinstance(body, Invariants):
        body = invariants_to_sid(body)
    if not isinstance(body, SIDBody):
        raise DataError(f"cannot write {type(body).__name__} as SID", os.fspath(path))
    nq = body.nq
    header = body.header or f"{len(body.nodes):5d}{nq:4d}    :No. nodes, No. modes:" \
                            "File created by neweul-py"
    out = [*header.splitlines(), " part ", _kv(6, "new modal", ""), " " * 11 + "refmod "]
    out.append(_kv(16, "mass", _fmt_float(body.mass, digits)))
    out.append(_kv(16, "nelastq", f"{nq:6d}"))
    out.extend(_kv(16, f"ielastq ({i:4d})", " " + name)
               for i, name in enumerate(body.ielastq, 1))
    out.append(" " * 11 + "end refmod ")
    out.append(" " * 11 + "frame ")
    for n in body.nodes:
        out.append(_kv(16, "new node", f"    {n.id}"))
        out.append(_kv(21, "rframe", f"    {n.rframe}"))
        for name, t in (("origin", n.origin), ("phi", n.phi), ("psi", n.psi),
                        ("AP", n.AP), *n.extra.items()):
            _write_taylor(out, 21, name, t, digits)
        out.append(" " * 16 + "end node")
    out.append(" " * 11 + "end frame ")
    for name, t in body.taylors.items():
        _write_taylor(out, 11, name, t, digits)
    out += [" " * 6 + "end modal ", " end part ", ""]
    atomic_write(path, "\n".join(out))


def invariants_from_sid(body: SIDBody, *, gr_layout: str = "auto", ge_layout: str = "auto"
                        ) -> Invariants:
    """The invariants of a :class:`SIDBody` (one-sided).

    Parameters
    ----------
    body
        The SID data.
    gr_layout, ge_layout
        Column layout of ``Gr`` (3×3nq) and ``Ge`` (nq×3nq) in the file: ``"mode"``
        (``[G_1 | … | G_nq]``, 3 columns per mode, column ``3(k−1)+b``) or
        ``"component"`` (``[G^x | G^y | G^z]``, nq columns per ω component, column
        ``(b−1)·nq+k``). Exporters differ (the SIMPACK-style file of EMBS_ModelicaLib
        uses ``"component"`` for both, the PY_SID beam file ``"mode"`` for ``Gr`` and
        ``"component"`` for ``Ge``). ``"auto"`` picks the layout in which the block
        satisfies its kinematic identity with the first-order terms, ``sym Gr_k = J¹_k``
        and ``Ge_k = 2 Cr¹_k``, falling back to ``"mode"`` when these are zero or
        equally good (always the case for nq = 1).

    Notes
    -----
    Missing blocks are zero. SID holds one rotational coupling ``Cr``; the rigid-row
    coupling is ``Crv = Cr⁰ + antisym(Cr¹)`` (antisymmetric in row and mode: the kinematic
    part ``∫ Φ_iᵀ Φ̃_kᵀ dm``; the symmetric part of ``Cr¹`` is geometric stiffening and
    acts in the elastic rows only). ``J`` is expanded to 3×3; ``Gr``/``Ge`` are stored per
    mode here.
    """
    nq = body.nq

    def tay(name: str, shape: tuple[int, int], order: int = 0) -> Taylor:
        t = body.get(name)
        if t is None:
            return Taylor.from_arrays(np.zeros(shape),
                                      np.zeros((shape[0], nq, shape[1])) if order else None,
                                      nq=nq)
        return t

    J = j_as_matrix(tay("J", (3, 3), 1)).with_order(1)
    Cr = tay("Cr", (nq, 3))
    Gr = _per_mode(tay("Gr", (3, 3 * nq)), nq, gr_layout, "Gr",
                   lambda b: np.abs(0.5 * (b + b.transpose(0, 2, 1))
                                    - J.m1.transpose(1, 0, 2)).max())
    cr1 = Cr.m1 if Cr.m1 is not None else np.zeros((nq, nq, 3))
    Ge = _per_mode(tay("Ge", (nq, 3 * nq)), nq, ge_layout, "Ge",
                   lambda b: np.abs(b - 2 * cr1.transpose(1, 0, 2)).max())
    # rigid-row coupling: the kinematic part of Cr¹ is antisymmetric in (row, mode), the
    # geometric stiffening (Wᵀ K_G V, one-sided) symmetric; only the former belongs there
    Crv = Taylor.from_arrays(Cr.m0, None if Cr.m1 is None else
                             0.5 * (Cr.m1 - Cr.m1.transpose(1, 0, 2)), nq=nq)
    nodes = tuple(NodeFrame(n.id, n.origin, n.phi, n.psi, n.AP) for n in body.nodes)
    return Invariants(
        m=body.mass, md=tay("mdCM", (3, 1), 1).with_order(1), J=J,
        Ct=tay("Ct", (nq, 3)), Cr=Cr, Crv=Crv, Me=tay("Me", (nq, nq)), Gr=Gr, Ge=Ge,
        Oe=tay("Oe", (nq, 6), 1).with_order(1), ksigma=tay("ksigma", (nq, 1)),
        Ke=tay("Ke", (nq, nq)), De=tay("De", (nq, nq)), nodes=nodes, names=body.ielastq)


def invariants_to_sid(inv: Invariants, header: str = "", layout: str = "component") -> SIDBody:
    """A :class:`SIDBody` of one-sided invariants.

    ``J`` is written 6×1, ``Gr`` and ``Ge`` in ``layout`` (``"component"``, as in
    SIMPACK-style files, or ``"mode"``; see :func:`invariants_from_sid`), ``Crv`` is dropped (SID
    has one ``Cr``); each block gets its most compact structure flag.

    Raises
    ------
    DataError
        For two-sided data (the SID format holds one basis).
    """
    if inv.two_sided:
        raise DataError("two-sided invariants cannot be written as SID (one basis only)",
                        item="two_sided")
    if layout not in ("mode", "component"):
        raise DataError(f"layout must be 'mode' or 'component', got {layout!r}",
                        item="layout")
    nq = inv.nq

    def out(t: Taylor) -> Taylor:
        t = Taylor(t.order, t.nrow, t.ncol, nq, 0, 3, t.m0, t.m1)
        return t.with_structure(None)

    def gyro(name: str) -> Taylor:
        blocks = inv.blocks(name)                       # (k, row, b)
        order = (1, 0, 2) if layout == "mode" else (1, 2, 0)
        m0 = blocks.transpose(*order).reshape(blocks.shape[1], 3 * nq)
        return out(Taylor.from_arrays(m0, nq=nq))

    taylors = {"mdCM": out(inv.md), "J": out(j_as_column(inv.J)), "Ct": out(inv.Ct),
               "Cr": out(inv.Cr), "Me": out(inv.Me), "Gr": gyro("Gr"),
               "Ge": gyro("Ge"), "Oe": out(inv.Oe), "ksigma": out(inv.ksigma),
               "Ke": out(inv.Ke), "De": out(inv.De)}
    nodes = tuple(SIDNode(n.id, "body ref", out(n.origin), out(n.phi), out(n.psi),
                          out(n.AP)) for n in inv.nodes)
    return SIDBody(inv.m, inv.names, nodes, taylors, header)


def _per_mode(t: Taylor, nq: int, layout: str, name: str, misfit) -> Taylor:
    """A SID ``Gr``/``Ge`` block in the per-mode layout (:func:`invariants_from_sid`)."""
    if layout not in ("auto", "mode", "component"):
        raise DataError(f"layout must be 'auto', 'mode' or 'component', got {layout!r}",
                        item=name)
    rows = t.m0.shape[0]
    by_mode = t.m0.reshape(rows, nq, 3).transpose(1, 0, 2)          # (k, row, b)
    by_comp = t.m0.reshape(rows, 3, nq).transpose(2, 0, 1)
    if layout == "auto":
        layout = "component" if misfit(by_comp) < misfit(by_mode) else "mode"
    blocks = by_comp if layout == "component" else by_mode
    return Taylor.from_arrays(blocks.transpose(1, 0, 2).reshape(rows, 3 * nq), nq=nq)
