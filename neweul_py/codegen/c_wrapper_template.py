"""Template of the Python side of compiled modules (see :mod:`.c_module`).

The text below the ``template begins`` line is copied verbatim into every ``<name>_c.py``,
after the run-time code (:mod:`.c_runtime`) and the module settings (``_MODEL_NAME``,
``_TWIN_FILE``, ``_C_FILE``, ``_C_SHA256``, ``_C_JAC_FILE``, ``_C_JAC_SHA256``, the sizes
``_N`` ``_NU`` ``_NP`` ``_NY`` ``_NC``, ``_CDEF``). The placeholders above the line only
make this file lintable; it is read as text by :func:`.c_module.render_c_wrapper`, never
imported.

Every protocol function checks the shapes of its arguments (the library reads exactly the sizes
it was built for: a wrong size is a ``ValueError``, never an out-of-bounds read), passes the
arrays' buffers to the library (``ffi.from_buffer``, no copies for float64 arrays) and returns
fresh arrays; ``u=None`` is passed as ``NULL``: the library evaluates the default excitation
itself. A singular mass matrix raises ``numpy.linalg.LinAlgError`` like ``numpy.linalg.solve``.
The derivative library is built (or verified) at the first call of a Jacobian function; if it
cannot be had, those functions fall back to the twin's, with one warning.

Models with elastic bodies (``_C_DATA`` not empty): each library is bound to the arrays of
the twin's data file (``nw_bind``, the twin's ``_DATA`` by the keys of ``_C_DATA``, no
copies; what is derived from its arrays, ``_C_DERIVED``: a parametric body's first row of
samples and its index tables as float64, made once) right after loading; a schedule outside
the sampled range (the library's code 3) is reported by calling the twin, whose message
names the body, the value and the range.
"""

from pathlib import Path as _Path

from .c_runtime import BackendUnavailable, compiled_library, load_twin

_MODEL_NAME = _TWIN_FILE = _C_FILE = _C_SHA256 = _C_JAC_FILE = _C_JAC_SHA256 = _CDEF = ""
_N = _NU = _NP = _NY = _NC = _LOSS = 0
_C_DATA: tuple = ()
_C_DERIVED: dict = {}

# ---- template begins
import threading as _threading  # noqa: E402
import warnings as _warnings  # noqa: E402

import numpy as _np  # noqa: E402

_HERE = _Path(__file__).resolve().parent
_twin = load_twin(_HERE / _TWIN_FILE, f"{__name__}__numpy")
for _name, _value in vars(_twin).items():
    if _name.isupper() or _name == "_P0":
        globals()[_name] = _value
_S = 2 * _N
default_parameters = _twin.default_parameters
# protocol functions the library does not implement: the twin's (energy, poses of the frames,
# the reaction Jacobian G_R = G_s S_W of modules with elastic bodies — the library's
# constraint_jacobian is G = G_s S_V, which differs from it at node frames of two-sided bodies —
# the directional second derivatives of docs/sensitivity.md, and for modules with elastic
# bodies the loss matrix)
for _name in ("energy", "frame_poses", "body_properties", "node_positions",
              "constraint_reaction_jacobian", "default_inputs_parameter_jacobian",
              "force_jacobians_directional", "mass_matrix_directional",
              "mass_matrix_times_derivative_directional", "output_jacobians_directional",
              "loss_matrix_directional", *(("loss_matrix",) if _C_DATA else ())):
    if callable(getattr(_twin, _name, None)):
        globals()[_name] = getattr(_twin, _name)
_BOUND = []     # the pointers bound into the libraries, kept alive with the module


def _derived(kind, keys):
    """An array bound that is no member of the data file (``_C_DERIVED``; as the generator's
    ``codegen.c_splice_trace.derived_array``): a parametric body's first row of samples, or
    one of its index tables as float64."""
    members = [_twin._DATA[k] for k in keys]
    if kind == "row0":
        base, rows, index, varying, mirror, scaled = members
        return _np.ascontiguousarray(_twin.ffrf_expand(base, rows[:1], index, varying[:1],
                                                       mirror, scaled).reshape(-1))
    return _np.ascontiguousarray(_np.asarray(members[0], dtype=_np.float64).reshape(-1))


def _bind(ffi, lib):
    """Bind ``lib`` to the twin's data-file arrays ``_C_DATA`` (models with elastic bodies)."""
    if not _C_DATA:
        return lib
    arrays = [_derived(*_C_DERIVED[k]) if k in _C_DERIVED else _twin._DATA[k] for k in _C_DATA]
    views = [ffi.from_buffer("double[]", a) for a in arrays]
    pointers = ffi.new("const double *[]", [ffi.cast("const double *", v) for v in views])
    sizes = ffi.new("long[]", [int(a.size) for a in arrays])
    if lib.nw_bind(len(arrays), pointers, sizes):
        raise BackendUnavailable("the library does not accept the data file's arrays")
    _BOUND.append((arrays, views, pointers, sizes))
    return lib


try:
    _ffi, _lib, _note = compiled_library(_HERE / _C_FILE, _C_SHA256, _CDEF,
                                         _HERE / "__neweul_c__")
    _bind(_ffi, _lib)
except BackendUnavailable as _exc:
    _ffi = _lib = None
    BACKEND = "numpy"
    BACKEND_ERROR = str(_exc)
    BACKEND_NOTE = (f"model {_MODEL_NAME!r}: compiled backend unavailable ({_exc}); using the "
                    f"NumPy module {_TWIN_FILE}")
    _warnings.warn(BACKEND_NOTE, RuntimeWarning, stacklevel=2)
else:
    BACKEND = "c"
    BACKEND_ERROR = ""
    BACKEND_NOTE = _note
    if _note not in ("", "built"):
        _warnings.warn(f"model {_MODEL_NAME!r}: {_note}", RuntimeWarning, stacklevel=2)

if _lib is None:
    default_inputs = _twin.default_inputs
    mass_matrix = _twin.mass_matrix
    force_vector = _twin.force_vector
    rhs = _twin.rhs
    force_jacobians = _twin.force_jacobians
    mass_matrix_times_derivative = _twin.mass_matrix_times_derivative
    rhs_jacobian = _twin.rhs_jacobian
    outputs = _twin.outputs
    output_jacobians = _twin.output_jacobians
    if _LOSS:
        loss_matrix = _twin.loss_matrix
    constraints = _twin.constraints
    constraint_jacobian = _twin.constraint_jacobian
    constraint_time_derivative = _twin.constraint_time_derivative
    constraint_gamma = _twin.constraint_gamma
    force_parameter_jacobian = _twin.force_parameter_jacobian
    mass_matrix_parameter_derivative = _twin.mass_matrix_parameter_derivative
    rhs_parameter_jacobian = _twin.rhs_parameter_jacobian
    output_parameter_jacobian = _twin.output_parameter_jacobian
else:
    _fb = _ffi.from_buffer
    _NULL = _ffi.NULL
    # the libraries of models with elastic bodies keep state between calls (the mixed samples,
    # the factorization of the elastic block) and release the GIL: one call at a time
    _lock = _threading.Lock()
    _as = _np.ascontiguousarray
    _f8 = _np.float64

    def _arr(v, size, what):
        a = _as(v, dtype=_f8)
        if a.shape != (size,):
            raise ValueError(f"{what} must have shape ({size},), got {a.shape}")
        return _fb("double[]", a)

    def _inputs(u):
        return _NULL if u is None else _arr(u, _NU, "u")

    def _failed(code, twin_call):
        """A call of the library returned ``code``: 1 — a singular mass matrix; 3 — a schedule
        outside its samples (the twin raises its ``ValueError`` naming the body and range)."""
        if code == 1:
            raise _np.linalg.LinAlgError("Singular matrix")
        if code == 3:
            twin_call()
            raise ValueError(f"model {_MODEL_NAME!r}: a schedule outside the sampled range")
        raise RuntimeError(f"model {_MODEL_NAME!r}: the compiled library failed ({code})")

    def default_inputs(t, p):
        """The default excitation ``u(t)`` of the description."""
        out = _np.empty(_NU)
        with _lock:
            _lib.nw_default_inputs(float(t), _arr(p, _NP, "p"), _fb("double[]", out))
        return out

    def mass_matrix(t, y, p, u=None):
        """Mass matrix ``M(y, t)``, shape (n, n)."""
        out = _np.empty((_N, _N))
        with _lock:
            code = _lib.nw_mass_matrix(float(t), _arr(y, _N, "y"), _arr(p, _NP, "p"), _inputs(u),
                                       _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.mass_matrix(t, y, p, u))
        return out

    def force_vector(t, y, yd, p, u=None):
        """Generalized forces ``q − k``, shape (n,)."""
        out = _np.empty(_N)
        with _lock:
            code = _lib.nw_force_vector(float(t), _arr(y, _N, "y"), _arr(yd, _N, "yd"),
                                        _arr(p, _NP, "p"), _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.force_vector(t, y, yd, p, u))
        return out

    # rhs is the hot path of every integrator: its arguments are copied into one buffer
    # whose C pointers are made once (three ``from_buffer`` calls cost more than the copies);
    # the library releases the GIL during the call, so a lock guards the shared buffer.
    _rbuf = _np.zeros(2 * _S + _NP)  # x | out | p
    _rx, _ro, _rp = _rbuf[:_S], _rbuf[_S:2 * _S], _rbuf[2 * _S:]
    _rxp = _fb("double[]", _rbuf)
    _rop, _rpp = _rxp + _S, _rxp + 2 * _S
    _rlock = _lock
    _nw_rhs = _lib.nw_rhs

    def rhs(t, x, p, u=None):
        """First-order form ``[ẏ, M⁻¹(q − k)]`` of the equations of motion."""
        x = _as(x, dtype=_f8)
        p = _as(p, dtype=_f8)
        if x.shape != (_S,) or p.shape != (_NP,):
            raise ValueError(f"x and p must have shapes ({_S},), ({_NP},); "
                             f"got {x.shape}, {p.shape}")
        up = _NULL if u is None else _arr(u, _NU, "u")
        with _rlock:
            _rx[...] = x
            _rp[...] = p
            code = _nw_rhs(float(t), _rxp, _rpp, up, _rop)
            if not code:
                return _ro.copy()
        _failed(code, lambda: _twin.rhs(t, x, p, u))

    _jac = []

    def _jac_lib():
        """The derivative library, built or verified at the first call (``None``: twin)."""
        if not _jac:
            try:
                _, lib, note = compiled_library(_HERE / _C_JAC_FILE, _C_JAC_SHA256, _CDEF,
                                                _HERE / "__neweul_c__", ffi=_ffi)
                _bind(_ffi, lib)
            except BackendUnavailable as exc:
                lib, note = None, (f"compiled derivatives unavailable ({exc}); using those of "
                                   f"the NumPy module {_TWIN_FILE}")
            if note not in ("", "built"):
                _warnings.warn(f"model {_MODEL_NAME!r}: {note}", RuntimeWarning, stacklevel=3)
            _jac.append(lib)
        return _jac[0]

    def force_jacobians(t, y, yd, p, u=None):
        """``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` (n, n) and ``∂(q−k)/∂u`` (n, nu), analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.force_jacobians(t, y, yd, p, u)
        out = _np.empty((_N, 2 * _N + _NU))
        with _lock:
            code = lib.nw_force_jacobians(float(t), _arr(y, _N, "y"), _arr(yd, _N, "yd"),
                                          _arr(p, _NP, "p"), _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.force_jacobians(t, y, yd, p, u))
        return out[:, :_N], out[:, _N:2 * _N], out[:, 2 * _N:]

    def mass_matrix_times_derivative(t, y, p, a, u=None):
        """``∂(M(y) a)/∂y`` for a fixed vector ``a``, shape (n, n)."""
        lib = _jac_lib()
        if lib is None:
            return _twin.mass_matrix_times_derivative(t, y, p, a, u)
        out = _np.empty((_N, _N))
        with _lock:
            code = lib.nw_mass_matrix_times_derivative(float(t), _arr(y, _N, "y"),
                                                       _arr(p, _NP, "p"), _arr(a, _N, "a"),
                                                       _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.mass_matrix_times_derivative(t, y, p, a, u))
        return out

    def rhs_jacobian(t, x, p, u=None):
        """``∂ rhs/∂x`` = [[0, I], [M⁻¹(∂f/∂y − ∂(M ÿ)/∂y), M⁻¹ ∂f/∂ẏ]], analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.rhs_jacobian(t, x, p, u)
        out = _np.empty((_S, _S))
        with _lock:
            code = lib.nw_rhs_jacobian(float(t), _arr(x, _S, "x"), _arr(p, _NP, "p"), _inputs(u),
                                       _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.rhs_jacobian(t, x, p, u))
        return out

    def outputs(t, x, p, u=None):
        """The outputs, ordered as ``OUTPUTS``."""
        out = _np.empty(_NY)
        with _lock:
            code = _lib.nw_outputs(float(t), _arr(x, _S, "x"), _arr(p, _NP, "p"), _inputs(u),
                                   _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.outputs(t, x, p, u))
        return out

    def output_jacobians(t, x, p, u=None):
        """``∂out/∂x`` (ny, STATE_SIZE) and ``∂out/∂u`` (ny, nu), analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.output_jacobians(t, x, p, u)
        out = _np.empty((_NY, _S + _NU))
        with _lock:
            code = lib.nw_output_jacobians(float(t), _arr(x, _S, "x"), _arr(p, _NP, "p"),
                                           _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.output_jacobians(t, x, p, u))
        return out[:, :_S], out[:, _S:]

    if _LOSS:
        def loss_matrix(t, x, p, u=None):
            """Hysteretic matrix ``G`` of ``K + iG`` (loss factors), shape (n, n)."""
            lib = _jac_lib()
            if lib is None:
                return _twin.loss_matrix(t, x, p, u)
            out = _np.empty((_N, _N))
            lib.nw_loss_matrix(float(t), _arr(x, _S, "x"), _arr(p, _NP, "p"), _inputs(u),
                               _fb("double[]", out))
            return out

    def force_parameter_jacobian(t, y, yd, p, u=None):
        """``∂(q−k)/∂p`` (n, np) at fixed ``u``, analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.force_parameter_jacobian(t, y, yd, p, u)
        out = _np.empty((_N, _NP))
        with _lock:
            code = lib.nw_force_parameter_jacobian(float(t), _arr(y, _N, "y"),
                                                   _arr(yd, _N, "yd"), _arr(p, _NP, "p"),
                                                   _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.force_parameter_jacobian(t, y, yd, p, u))
        return out

    def mass_matrix_parameter_derivative(t, y, p, a, u=None):
        """``∂(M(y) a)/∂p`` (n, np) for a fixed vector ``a``, analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.mass_matrix_parameter_derivative(t, y, p, a, u)
        out = _np.empty((_N, _NP))
        with _lock:
            code = lib.nw_mass_matrix_parameter_derivative(float(t), _arr(y, _N, "y"),
                                                           _arr(p, _NP, "p"), _arr(a, _N, "a"),
                                                           _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.mass_matrix_parameter_derivative(t, y, p, a, u))
        return out

    def rhs_parameter_jacobian(t, x, p, u=None):
        """``∂ rhs/∂p = [0; M⁻¹(∂(q−k)/∂p − ∂(M ÿ)/∂p)]`` (STATE_SIZE, np) at fixed ``u``,
        analytic."""
        x = _as(x, dtype=_f8)
        if u is None:
            u = default_inputs(t, p)
        y, yd = x[:_N], x[_N:_S]
        M = mass_matrix(t, y, p, u)
        ydd = _np.linalg.solve(M, force_vector(t, y, yd, p, u))
        J = _np.zeros((_S, _NP))
        if _NP:
            J[_N:] = _np.linalg.solve(M, force_parameter_jacobian(t, y, yd, p, u)
                                      - mass_matrix_parameter_derivative(t, y, p, ydd, u))
        return J

    def output_parameter_jacobian(t, x, p, u=None):
        """``∂out/∂p`` (ny, np) at fixed state and ``u``, analytic."""
        lib = _jac_lib()
        if lib is None:
            return _twin.output_parameter_jacobian(t, x, p, u)
        out = _np.empty((_NY, _NP))
        with _lock:
            code = lib.nw_output_parameter_jacobian(float(t), _arr(x, _S, "x"),
                                                    _arr(p, _NP, "p"), _inputs(u),
                                                    _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.output_parameter_jacobian(t, x, p, u))
        return out

    def _positional(name, size, t, y, p, u):
        out = _np.empty(size)
        with _lock:
            code = getattr(_lib, f"nw_{name}")(float(t), _arr(y, _N, "y"), _arr(p, _NP, "p"),
                                                _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: getattr(_twin, name)(t, y, p, u))
        return out

    def constraints(t, y, p, u=None):
        """Holonomic constraints ``g(y, t)``, ordered as ``CONSTRAINTS``."""
        return _positional("constraints", _NC, t, y, p, u)

    def constraint_jacobian(t, y, p, u=None):
        """``G = ∂g/∂y``, shape (nc, n), analytic."""
        return _positional("constraint_jacobian", (_NC, _N), t, y, p, u)

    def constraint_time_derivative(t, y, p, u=None):
        """``∂g/∂t`` (explicit time dependence, through inputs), shape (nc,)."""
        return _positional("constraint_time_derivative", _NC, t, y, p, u)

    def constraint_gamma(t, y, yd, p, u=None):
        """``γ`` with ``G ÿ + γ = 0``, shape (nc,)."""
        out = _np.empty(_NC)
        with _lock:
            code = _lib.nw_constraint_gamma(float(t), _arr(y, _N, "y"), _arr(yd, _N, "yd"),
                                            _arr(p, _NP, "p"), _inputs(u), _fb("double[]", out))
        if code:
            _failed(code, lambda: _twin.constraint_gamma(t, y, yd, p, u))
        return out

    def integrate_dopri5(t_start, t_end, x0, p, t_eval, u=None, rtol=1e-6, atol=1e-9,
                         max_step=float("inf")):
        """Dormand–Prince 5(4) in C with the step control of SciPy's RK45 (no Python call
        per step); ``u``: ``None`` (default excitation) or a constant input vector.

        Returns
        -------
        x_eval, nfev, status, t_reached
            States at ``t_eval`` (rows), right-hand-side evaluations, 0 (done), 1 (step too
            small), 2 (singular mass matrix) or 3 (non-finite state), and the time reached.
        """
        te = _as(t_eval, dtype=_f8).reshape(-1)
        x_eval = _np.full((te.size, _S), _np.nan)
        nfev = _ffi.new("long *")
        reached = _ffi.new("double *")
        with _lock:
            status = _lib.nw_integrate_dopri5(
                float(t_start), float(t_end), _arr(x0, _S, "x0"), _arr(p, _NP, "p"),
                _inputs(u), float(rtol), float(atol), float(max_step), te.size,
                _fb("double[]", te), _fb("double[]", x_eval), nfev, reached)
        return x_eval, int(nfev[0]), int(status), float(reached[0])

    def generalized_alpha_steps(t0, t1, first, last, steps, coefficients, p, u, Si, rtol, atol,
                                state, flags, work, t_eval, x_eval, counters):
        """Steps ``first … last − 1`` of the generalized-α method in C (``nw_integrate_galpha``,
        driven by ``neweul_py.analysis.generalized_alpha``): ``state`` (y, ẏ, ÿ, a),
        ``flags`` (θ, fresh, retry), ``work`` (the run's: ``S⁻¹``, n² + 3n + 1), ``x_eval`` and
        ``counters`` (the next output, rhs-like evaluations, the steps done) are updated in
        place; ``Si`` the inverse of the new iteration matrix ``S`` or ``None`` (keep it);
        ``u``: ``None`` or constant inputs.

        Returns
        -------
        int
            0 done, 1 rebuild the matrix, 2 Newton's method failed with a rebuilt matrix,
            4 + the library's code of a failed evaluation.
        """
        k, nfev, done = (_ffi.new("long *", int(v)) for v in counters)
        for arr, size in ((state, 4 * _N), (flags, 3), (work, _N * _N + 3 * _N + 1),
                          (x_eval, x_eval.size)):
            if arr.dtype != _f8 or not arr.flags.c_contiguous or arr.size != size:
                raise ValueError("state, flags, work and x_eval: contiguous float64 arrays of "
                                 "their sizes")
        te = _as(t_eval, dtype=_f8).reshape(-1)
        if x_eval.size != te.size * _S:
            raise ValueError("x_eval must hold one state per output time")
        with _lock:
            status = _lib.nw_integrate_galpha(
                float(t0), float(t1), int(first), int(last), int(steps),
                _arr(coefficients, 13, "coefficients"), _arr(p, _NP, "p"), _inputs(u),
                _NULL if Si is None else _arr(_np.reshape(Si, -1), _N * _N, "Si"), float(rtol),
                _arr(atol, _S, "atol"), _fb("double[]", state), _fb("double[]", flags),
                _fb("double[]", work), te.size, _fb("double[]", te), _fb("double[]", x_eval),
                k, nfev, done)
        counters[:] = [int(k[0]), int(nfev[0]), int(done[0])]
        return int(status)
