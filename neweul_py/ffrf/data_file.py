"""The data file of a generated module: its elastic arrays, by reference (protocol docs).

A generated module with elastic bodies holds equations, not data. Its arrays — the prepared
body data of :func:`neweul_py.ffrf.splice.ffrf_bodies` (for a parametric body the stacked
samples it mixes), the node maps ``S_V``, ``S_W`` and the node clouds — are written next to
it as one uncompressed ``.npz`` file, which the module names with its SHA-256 and loads at
import (:func:`ffrf_load_data`):

* **Deterministic bytes.** :func:`data_file_bytes` writes the zip archive itself: members in
  sorted order, ``STORED`` (no compression), the DOS date 1980-01-01 00:00, no
  platform-dependent attributes, and the ``.npy`` headers of format 1.0 written here too;
  so the same arrays give the same bytes under any NumPy, Python or operating system. Each
  member's array data start at a multiple of 64 bytes in the file (an alignment record in
  the local header's extra field, as Android's ``zipalign`` writes), so that they can be
  memory-mapped. NumPy reads the file with ``numpy.load`` like any ``.npz``.
* **Memory-mapped, checked, before any work.** :func:`ffrf_load_data` maps the file
  read-only, hashes the mapped bytes, finds every member through the zip's central directory
  and returns read-only arrays that view the mapping (no copy: a module imported in several
  processes shares the pages). A missing file, other bytes (SHA-256), or another schema
  (names, dtypes, shapes) is one :class:`ElasticDataError` naming the body, the file and
  what differs, raised at import.
* **A body file by reference.** A parametric body's sample stack may instead be read from
  the body file it was generated from, named relative to the module with its SHA-256
  (:func:`ffrf_load_sources`, :func:`ffrf_stack_parts`; chosen at generation by
  :mod:`neweul_py.codegen.body_reference`).
* **Stored compactly, used in full.** :func:`ffrf_encode` stores a floating-point array
  that is mostly zeros (the node maps ``S_V``, ``S_W``, a parametric body's base of
  constant entries) as its nonzero values and a bit per entry (``<key>@nonzero``,
  :func:`numpy.packbits`), an integer array whose values fit as ``int32`` (the index tables
  of a mixing stack); the module names these encodings and :func:`ffrf_decode` gives the
  arrays back, equal bit for bit, after the file is checked.
* **Skeleton and arrays.** :func:`ffrf_split` replaces every array of a nested structure of
  dicts, lists and tuples by a reference ``{"@": key}`` (arrays of equal bytes are stored
  once); the rest is a Python literal the module prints. :func:`ffrf_restore` puts the
  arrays back.

The functions named ``ffrf_*`` and :class:`ElasticDataError` are embedded in generated
modules (NumPy and the standard library only); :func:`ffrf_split` and
:func:`data_file_bytes` run at generation.
"""

from __future__ import annotations

import hashlib
import mmap
import os
import stat
import struct

import numpy as np

__all__ = [
    "DATA_FUNCTIONS",
    "ArrayStore",
    "ElasticDataError",
    "data_file_bytes",
    "ffrf_decode",
    "ffrf_encode",
    "ffrf_load_data",
    "ffrf_load_sources",
    "ffrf_restore",
    "ffrf_split",
    "ffrf_stack_parts",
    "schema_of",
]

#: Alignment of the array data in the file (bytes).
ALIGN = 64
#: Largest data file written (the zip format without its 64-bit extension).
MAX_BYTES = 2**32 - 1


#: The member holding the nonzero pattern of an array stored as its nonzeros.
NONZERO_SUFFIX = "@nonzero"


class ElasticDataError(ValueError):
    """A data file of a generated module is missing, changed or of another schema."""


def _npy_header(descr: str, shape: tuple[int, ...], start: int) -> bytes:
    """The ``.npy`` header (format 1.0) of a C-ordered array; padded so that the array data
    begin at a multiple of :data:`ALIGN` when the member begins at ``start``."""
    text = f"{{'descr': {descr!r}, 'fortran_order': False, 'shape': {tuple(shape)!r}, }}"
    fixed = 10 + len(text) + 1
    pad = -(start + fixed) % ALIGN
    head = (text + " " * pad + "\n").encode("latin1")
    if len(head) > 65535:
        raise ValueError("an array of too many dimensions for the .npy format 1.0")
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(head)) + head


def data_file_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """The bytes of the data file holding ``arrays`` (module docstring): an uncompressed
    ``.npz`` with members ``<key>.npy`` in sorted order, each array's data 64-byte aligned.

    Raises
    ------
    ValueError
        A key that is not a plain relative name, an object array, or more than 4 GiB.
    """
    out = bytearray()
    central = bytearray()
    count = 0
    for key in sorted(arrays):
        if not key or key.startswith("/") or ".." in key.split("/") or "\\" in key:
            raise ValueError(f"data file key {key!r} is not a plain relative name")
        arr = np.asarray(arrays[key])
        if arr.dtype.hasobject:
            raise ValueError(f"data file array {key!r} holds Python objects")
        arr = _c_order(
            arr.astype(arr.dtype.newbyteorder("<")) if arr.dtype.byteorder == ">" else arr
        )
        name = f"{key}.npy".encode()
        offset = len(out)
        # the local header (30 bytes), the name, an alignment record so that the member
        # (and with the .npy padding its array data) starts at a multiple of ALIGN
        extra_len = -(offset + 30 + len(name) + 4) % ALIGN + 4
        extra = struct.pack("<HH", 0xD935, extra_len - 4) + b"\0" * (extra_len - 4)
        start = offset + 30 + len(name) + extra_len
        header = _npy_header(np.lib.format.dtype_to_descr(arr.dtype), arr.shape, start)
        payload = header + arr.tobytes()
        crc = _crc32(payload)
        size = len(payload)
        local = struct.pack(
            "<IHHHHHIIIHH", 0x04034B50, 20, 0, 0, 0, 0x21, crc, size, size, len(name), len(extra)
        )
        out += local + name + extra + payload
        central += (
            struct.pack(
                "<IHHHHHHIIIHHHHHII",
                0x02014B50,
                20,
                20,
                0,
                0,
                0,
                0x21,
                crc,
                size,
                size,
                len(name),
                0,
                0,
                0,
                0,
                0,
                offset,
            )
            + name
        )
        count += 1
        if len(out) > MAX_BYTES:
            raise ValueError("the elastic data exceed 4 GiB (the data file's zip format)")
    cd_offset = len(out)
    out += central
    out += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, count, count, len(central), cd_offset, 0)
    if len(out) > MAX_BYTES or count > 65535:
        raise ValueError("the elastic data exceed the data file's zip format (4 GiB, 65535 arrays)")
    return bytes(out)


def _c_order(arr: np.ndarray) -> np.ndarray:
    """``arr`` in C order (a copy only when it is not; 0-d arrays stay 0-d, unlike
    ``numpy.ascontiguousarray``)."""
    return arr if arr.flags.c_contiguous else arr.copy(order="C")


def _crc32(data: bytes) -> int:
    import zlib

    return zlib.crc32(data) & 0xFFFFFFFF


def schema_of(arrays: dict[str, np.ndarray]) -> dict[str, tuple[str, tuple[int, ...], str]]:
    """``key → (dtype descr, shape, SHA-256 of the array's bytes, 16 hex)`` of ``arrays``:
    what a module expects of its data file (the digests name the array that changed)."""
    out = {}
    for key in sorted(arrays):
        arr = _c_order(np.asarray(arrays[key]))
        out[key] = (
            np.lib.format.dtype_to_descr(arr.dtype),
            tuple(int(s) for s in arr.shape),
            hashlib.sha256(arr.tobytes()).hexdigest()[:16],
        )
    return out


class ArrayStore:
    """The arrays of a data file by key, each distinct array stored once (equal dtype, shape
    and bytes: one key, found by the SHA-256 of the bytes)."""

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}
        self._keys: dict[tuple[str, tuple[int, ...], str], str] = {}

    def put(self, key: str, array: np.ndarray) -> str:
        """Store ``array`` under ``key`` unless an equal one is stored; returns its key."""
        arr = _c_order(np.asarray(array))
        ident = (arr.dtype.str, arr.shape, hashlib.sha256(arr.tobytes()).hexdigest())
        known = self._keys.get(ident)
        if known is not None:
            return known
        if key in self.arrays:
            raise ValueError(f"data file key {key!r} used twice")
        self.arrays[key] = arr
        self._keys[ident] = key
        return key


def ffrf_encode(arrays: dict[str, np.ndarray]
                ) -> tuple[dict[str, np.ndarray], dict[str, list]]:
    """The arrays to write and their encodings (module docstring): a floating-point array of
    at least one axis whose nonzero values and bit mask take less than half its bytes is
    stored as those (``["nonzero", shape]``); a signed integer array of 64-bit values that
    all fit in 32 bits as ``int32`` (``["narrow", descr]``); the others as they are.
    :func:`ffrf_decode` inverts it exactly."""
    stored: dict[str, np.ndarray] = {}
    encodings: dict[str, list] = {}
    for key in sorted(arrays):
        a = _c_order(np.asarray(arrays[key]))
        if (a.dtype.kind == "f" and a.ndim and key + NONZERO_SUFFIX not in arrays
                and not key.endswith(NONZERO_SUFFIX)):
            flat = a.reshape(-1)
            nonzero = (flat != 0) | np.signbit(flat)        # a −0 is kept as it is
            mask = np.packbits(nonzero)
            if mask.nbytes + a.itemsize * int(nonzero.sum()) < a.nbytes // 2:
                stored[key] = np.ascontiguousarray(flat[nonzero])
                stored[key + NONZERO_SUFFIX] = mask
                encodings[key] = ["nonzero", [int(n) for n in a.shape]]
                continue
        if a.dtype.kind == "i" and a.itemsize == 8 and a.size and \
                np.iinfo(np.int32).min <= a.min() and a.max() <= np.iinfo(np.int32).max:
            stored[key] = a.astype(np.int32)
            encodings[key] = ["narrow", np.lib.format.dtype_to_descr(a.dtype)]
            continue
        stored[key] = a
    return stored, encodings


def ffrf_decode(arrays, encodings):
    """The arrays of a data file as the module uses them: those that :func:`ffrf_encode`
    stored compactly (``encodings``: key → ``["nonzero", shape]`` or ``["narrow", descr]``)
    in full, read-only; the others as they are (views of the file)."""
    out = dict(arrays)
    for key, spec in encodings.items():
        if spec[0] == "nonzero":
            shape = tuple(spec[1])
            size = int(np.prod(shape, dtype=np.int64))
            full = np.zeros(size, dtype=out[key].dtype)
            full[np.flatnonzero(np.unpackbits(out.pop(key + "@nonzero"), count=size))] = out[key]
            out[key] = full.reshape(shape)
        else:
            out[key] = out[key].astype(np.dtype(spec[1]))
        out[key].setflags(write=False)
    return out


def ffrf_split(tree, prefix: str, store: ArrayStore):
    """``tree`` with every ``numpy.ndarray`` replaced by ``{"@": key}`` (keys ``prefix/…``
    from the dict keys and list positions on its path) and put into ``store``; NumPy
    scalars become Python numbers; anything else must be a literal (``None``, ``bool``,
    ``int``, ``float``, ``str`` in dicts, lists and tuples).

    Raises
    ------
    TypeError
        A value that is neither an array nor a literal.
    """
    if isinstance(tree, np.ndarray):
        return {"@": store.put(prefix, tree)}
    if isinstance(tree, dict):
        return {k: ffrf_split(v, f"{prefix}/{k}", store) for k, v in tree.items()}
    if isinstance(tree, list | tuple):
        items = [ffrf_split(v, f"{prefix}/{i}", store) for i, v in enumerate(tree)]
        return items if isinstance(tree, list) else tuple(items)
    if isinstance(tree, np.bool_):
        return bool(tree)
    if isinstance(tree, np.integer):
        return int(tree)
    if isinstance(tree, np.floating):
        return float(tree)
    if tree is None or isinstance(tree, bool | int | float | str):
        return tree
    raise TypeError(f"{prefix}: {type(tree).__name__} is neither an array nor a literal")


def ffrf_restore(tree, arrays):
    """Inverse of :func:`ffrf_split`: references ``{"@": key}`` become ``arrays[key]``."""
    if isinstance(tree, dict):
        if len(tree) == 1 and "@" in tree:
            return arrays[tree["@"]]
        return {k: ffrf_restore(v, arrays) for k, v in tree.items()}
    if isinstance(tree, list):
        return [ffrf_restore(v, arrays) for v in tree]
    if isinstance(tree, tuple):
        return tuple(ffrf_restore(v, arrays) for v in tree)
    return tree


def ffrf_members(buf):
    """``name → (offset, size)`` of the stored members of the zip archive in ``buf`` (its
    central directory; ``offset``: the member's first byte after its local header), or
    ``None`` when ``buf`` is not such an archive."""
    end = buf.rfind(b"PK\x05\x06", max(0, len(buf) - 65557))
    if end < 0 or end + 22 > len(buf):
        return None
    count, _size, start = struct.unpack_from("<HII", buf, end + 10)
    members, pos = {}, start
    for _ in range(count):
        if pos + 46 > len(buf) or buf[pos : pos + 4] != b"PK\x01\x02":
            return None
        (method,) = struct.unpack_from("<H", buf, pos + 10)
        csize, usize, nlen, xlen, clen = struct.unpack_from("<IIHHH", buf, pos + 20)
        (local,) = struct.unpack_from("<I", buf, pos + 42)
        name = bytes(buf[pos + 46 : pos + 46 + nlen]).decode("utf-8", "replace")
        pos += 46 + nlen + xlen + clen
        if (
            local + 30 > len(buf)
            or buf[local : local + 4] != b"PK\x03\x04"
            or method != 0
            or csize != usize
        ):
            return None
        lnlen, lxlen = struct.unpack_from("<HH", buf, local + 26)
        members[name] = (local + 30 + lnlen + lxlen, usize)
    return members


def ffrf_npy(buf, offset, size):
    """``(descr, shape, data offset)`` of the ``.npy`` member at ``offset`` (``size`` bytes)
    of ``buf``, or ``None`` when it is not a C-ordered ``.npy`` array of version 1 or 2."""
    import ast

    if size < 10 or bytes(buf[offset : offset + 6]) != b"\x93NUMPY":
        return None
    major = buf[offset + 6]
    if major == 1:
        (hlen,) = struct.unpack_from("<H", buf, offset + 8)
        start = offset + 10
    elif major in (2, 3):
        (hlen,) = struct.unpack_from("<I", buf, offset + 8)
        start = offset + 12
    else:
        return None
    try:
        head = ast.literal_eval(bytes(buf[start : start + hlen]).decode("latin1"))
        descr, fortran, shape = head["descr"], head["fortran_order"], tuple(head["shape"])
    except (ValueError, SyntaxError, KeyError, TypeError):
        return None
    if fortran or not isinstance(descr, str):
        return None
    return descr, shape, start + hlen


def ffrf_data_problem(buf, members, schema):
    """What differs between the members of a data file and ``schema`` (key → descr, shape,
    digest): ``(key, words)`` of the first difference, or ``None``."""
    for key, (descr, shape, digest) in schema.items():
        at = members.get(f"{key}.npy")
        if at is None:
            return key, "is missing from the file"
        head = ffrf_npy(buf, *at)
        if head is None:
            return key, "is not a readable array"
        if head[0] != descr or head[1] != tuple(shape):
            return key, (
                f"has dtype {head[0]} and shape {head[1]}, the module expects "
                f"{descr} and {tuple(shape)}"
            )
        nbytes = int(np.dtype(descr).itemsize * np.prod(shape, dtype=np.int64))
        if head[2] + nbytes > at[0] + at[1]:
            return key, "is shorter than its shape"
        data = memoryview(buf)[head[2] : head[2] + nbytes]
        if hashlib.sha256(data).hexdigest()[:16] != digest:
            return key, "holds other values"
    extra = sorted(set(members) - {f"{k}.npy" for k in schema})
    if extra:
        return extra[0].removesuffix(".npy"), "is not an array of this module"
    return None


def ffrf_map(path, fail):
    """The bytes of the file ``path`` mapped read-only (``b""`` for an empty file);
    ``fail(words)`` (which raises) for a missing or unreadable one."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):     # a FIFO or a device would block
            fail("is not a regular file")
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            return mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) if size else b""
    except FileNotFoundError:
        fail("is missing")
    except OSError as exc:
        fail(f"cannot be read ({exc.strerror})")


def ffrf_load_data(directory, name, sha256, schema, owners):
    """The arrays of the data file ``directory/name`` as read-only views of its memory map,
    after checking its SHA-256 against ``sha256`` and, on a mismatch, naming what differs
    from ``schema`` (:func:`schema_of`); ``owners`` maps the first component of a key to
    the words naming what the array belongs to (``"elastic body 'duct'"``), and ``""`` to
    those naming every body (the file as a whole).

    Raises
    ------
    ElasticDataError
        The file is missing or unreadable, larger than the schema's arrays with their headers
        can be (refused before it is hashed), changed after generation, or of another
        schema: one message naming the body, the file and what differs.
    """
    path = os.path.join(directory, name)
    first = ""

    def fail(key, words):
        who = owners.get(key.split("/", 1)[0], owners.get("", "elastic data"))
        raise ElasticDataError(
            f"{who}: the data file {path} {words}; regenerate the "
            "module (its data file is written next to it)"
        )

    buf = ffrf_map(path, lambda words: fail(first, words))
    payload = sum(np.dtype(descr).itemsize * int(np.prod(shape, dtype=np.int64))
                  for descr, shape, _digest in schema.values())
    most = payload + 1024 * len(schema) + 65536     # headers, names, alignment: generous
    if len(buf) > most:       # refused before 8 GB are hashed
        fail(first, f"is not the data file of this module ({len(buf)} bytes; it has at "
                    f"most {most})")
    if hashlib.sha256(buf).hexdigest() != sha256:
        members = ffrf_members(buf)
        if members is None:
            fail(first, "is not the data file of this module (not an uncompressed .npz)")
        problem = ffrf_data_problem(buf, members, schema)
        if problem is None:
            fail(first, "changed after generation (its SHA-256 differs)")
        fail(problem[0], f"changed after generation: array {problem[0]!r} {problem[1]}")
    members = ffrf_members(buf)
    out = {}
    for key, (descr, shape, _digest) in schema.items():
        head = ffrf_npy(buf, *members[f"{key}.npy"])
        count = int(np.prod(shape, dtype=np.int64))
        out[key] = np.frombuffer(buf, dtype=np.dtype(descr), count=count, offset=head[2]).reshape(
            shape
        )
    return out


def ffrf_stack_parts(buf, members, parts):
    """The array that ``parts`` name in the uncompressed archive ``buf`` (its members by
    :func:`ffrf_members`): per part ``[names, scale]`` the members ``names`` — each (k, n),
    e.g. a parametric body's values, slopes and curvatures of one matrix — interleaved row by
    row into (k·len(names), n) and multiplied by ``scale`` (unless it is 1); the parts side
    by side. ``None`` when a member is missing, unreadable or of another row count."""
    blocks = []
    for names, scale in parts:
        stack = []
        for name in names:
            at = members.get(f"{name}.npy")
            head = None if at is None else ffrf_npy(buf, *at)
            if head is None or len(head[1]) != 2:
                return None
            count = int(np.prod(head[1], dtype=np.int64))
            if head[2] + count * np.dtype(head[0]).itemsize > at[0] + at[1]:
                return None
            stack.append(np.frombuffer(buf, dtype=np.dtype(head[0]), count=count,
                                       offset=head[2]).reshape(head[1]))
        if len({a.shape for a in stack}) != 1:
            return None
        block = np.stack(stack, axis=1).reshape(-1, stack[0].shape[1])
        blocks.append(block * scale if scale != 1.0 else block)
    if len({b.shape[0] for b in blocks}) != 1:
        return None
    out = np.hstack(blocks) if len(blocks) > 1 else blocks[0]
    out.setflags(write=False)
    return out


def ffrf_load_sources(directory, sources, owners):
    """The arrays a module reads from files other than its data file (a parametric body's
    sample stacks from the body file it was generated from, docs/generated-module-protocol.md):
    ``sources`` maps a file name relative to ``directory`` to ``{"sha256": hex, "bytes":
    size, "owner": body name, "arrays": {key: parts}}`` (:func:`ffrf_stack_parts`); each file
    is checked against its size (before it is hashed: a replaced file of gigabytes is refused
    at once) and its SHA-256 before it is read (``"bytes"`` may be absent: no size check).

    Raises
    ------
    ElasticDataError
        A file is missing, unreadable or changed after generation: one message naming the
        body and the file.
    """
    out = {}
    for name, spec in sources.items():
        path = os.path.normpath(os.path.join(directory, name))
        who = owners.get(spec["owner"], owners.get("", "elastic data"))

        def fail(words, who=who, path=path):
            raise ElasticDataError(
                f"{who}: the body file {path} {words}; the module reads the body's samples "
                "from it: regenerate the module"
            )

        buf = ffrf_map(path, fail)
        if spec.get("bytes", len(buf)) != len(buf):
            fail(f"changed after generation ({len(buf)} bytes, it had {spec['bytes']})")
        if hashlib.sha256(buf).hexdigest() != spec["sha256"]:
            fail("changed after generation (its SHA-256 differs)")
        members = ffrf_members(buf)
        for key, parts in spec["arrays"].items():
            out[key] = None if members is None else ffrf_stack_parts(buf, members, parts)
            if out[key] is None:
                fail(f"does not hold the arrays of {key!r} as the module expects")
    return out


#: The functions a generated module with elastic bodies embeds to read its data file.
DATA_FUNCTIONS = (ffrf_restore, ffrf_members, ffrf_npy, ffrf_data_problem, ffrf_map,
                  ffrf_load_data, ffrf_decode, ffrf_stack_parts, ffrf_load_sources)
