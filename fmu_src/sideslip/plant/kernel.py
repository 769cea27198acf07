"""The plant's, the driver's and the LQR controller's steps and SideslipFusion's scalar models compiled from C
(``native/plant_kernel.c``, ``native/driver_kernel.c``, ``sideslip/control/native/lqr_kernel.c``,
``sideslip/estimators/fusion/native/fusion_kernel.c``: one binary), loaded with ctypes.

The pure-Python models (:mod:`sideslip.plant.dynamics` and :class:`~sideslip.plant.vehicle.VehiclePlant`,
:class:`~sideslip.plant.driver.Driver`, :class:`~sideslip.control.dyc.LqrDycController`, SideslipFusion's kinematic
step, wheel-speed and tire measurements and magnetometer heading) are the reference; the C files repeat their
arithmetic operation for operation, so both give the same doubles on one platform (``tests/test_plant_kernel.py``,
``tests/test_driver_kernel.py``, ``tests/test_lqr_kernel.py`` and ``tests/test_fusion_kernel.py`` check them equal
to 1e-12, and bit-identical on Linux x86-64); the cost of each is in the Performance page.

Plain C without the Python API, so one binary serves every Python version; ctypes, not a C extension, because
the win64 FMUs are cross-compiled without a Windows Python to link against.  Where the binary comes from:

* inside an FMU: ``native/<platform>/sideslip_plant_kernel.so`` / ``.dll`` next to this module (both C files in one
  binary), compiled by the FMU build for linux64 and win64 (:func:`sideslip.fmi.build.compile_kernel`);
* the library: the ``sideslip.plant._plant_kernel`` binary setuptools compiles at install (``setup.py``).

The binary is loaded when this module is imported, which an FMU does at instantiation: some hosts delete the
unpacked FMU afterwards.  Without a binary for this platform (no compiler at install, another operating system)
the plant, the driver and the controller run the Python reference and :data:`UNAVAILABLE` says why.
"""
from __future__ import annotations

import ctypes
import importlib.machinery
import struct
import sys
from pathlib import Path

__all__ = ["CompiledStep", "PlantKernel", "DriverKernel", "LqrKernel", "FusionKernel", "available", "UNAVAILABLE",
           "LIBRARY_NAME", "PLATFORM", "N_STATE", "N_INPUTS", "N_OUTPUTS", "PLANT_IO", "FUSION_IO"]

LIBRARY_NAME = "sideslip_plant_kernel"
"""File name (without extension) of the binary an FMU carries."""
PLATFORM = {"linux": "linux64", "win32": "win64"}.get(sys.platform)
"""This machine's FMI platform folder, where an FMU's kernel is."""
KERNEL_VERSION = 5
"""Interface version the binary must report (``sideslip_plant_kernel_version``)."""
N_STATE, N_INPUTS, N_OUTPUTS = 15, 8, 24
"""The kernel's state (the plant's 14 states and the motors' torque difference), inputs and outputs."""
PLANT_IO = N_STATE + N_INPUTS + 3 + N_OUTPUTS
"""Values of one compiled plant step (plant_kernel.c ``IO_*``): the state, the inputs, the two cornering stiffnesses
and the step, the outputs."""
_PLANT_IN, _STATE, _PLANT_OUT = (struct.Struct(f"={n}d") for n in (PLANT_IO - N_OUTPUTS, N_STATE, N_OUTPUTS))


def _candidates():
    here = Path(__file__).resolve().parent
    if PLATFORM:
        yield here / "native" / PLATFORM / (LIBRARY_NAME + (".dll" if PLATFORM == "win64" else ".so"))
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        yield here / f"_plant_kernel{suffix}"


def _load():
    tried = []
    for path in _candidates():
        if not path.is_file():
            continue
        try:
            lib = ctypes.CDLL(str(path))
            version = lib.sideslip_plant_kernel_version()
        except (OSError, AttributeError) as exc:
            tried.append(f"{path.name}: {exc}")
            continue
        if version != KERNEL_VERSION:
            tried.append(f"{path.name}: interface version {version}, expected {KERNEL_VERSION}")
            continue
        lib.sideslip_plant_step.argtypes = None                  # (constants, io): the fastest ctypes call
        lib.sideslip_plant_step.restype = ctypes.c_int
        lib.sideslip_driver_step.argtypes = None                 # (byref(plan), io): the fastest ctypes call
        lib.sideslip_driver_step.restype = None
        lib.sideslip_lqr_step.argtypes = None                    # (byref(law), byref(design), io)
        lib.sideslip_lqr_step.restype = None
        for name in ("inputs", "kinematic", "wheel", "axles", "heading"):    # (constants, io[, arrays, n]): codes
            getattr(lib, f"sideslip_fusion_{name}").argtypes = None
            getattr(lib, f"sideslip_fusion_{name}").restype = ctypes.c_int
        return lib, ""
    why = ("; ".join(tried) if tried
           else "no compiled plant kernel for this platform (built at install with a C compiler)")
    return None, why


_LIB, UNAVAILABLE = _load()
"""The loaded binary (None without one) and, without one, why."""


def available() -> bool:
    """Whether the compiled plant step can run here."""
    return _LIB is not None


class CompiledStep:
    """What a model with a compiled step shares: :meth:`_compile` sets ``_native`` to the kernel's bound step where
    it runs (None where it does not); a pickled model carries no ctypes buffers and makes them again.  (An FMU state
    holds data only: it takes the bound step from a template of the same parameters.)"""

    _native = None

    def _compile(self) -> None:  # pragma: no cover - every user overrides it
        raise NotImplementedError

    @property
    def compiled(self) -> bool:
        """Whether the steps run the compiled kernel."""
        return self._native is not None

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_native"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._compile()


class PlantKernel:
    """The compiled step of one plant: its constants and the buffers the C function reads and writes.

    Parameters
    ----------
    constants : sequence of float
        The plant's constants in the order of the C ``Constants`` struct
        (:meth:`sideslip.plant.vehicle.VehiclePlant._kernel_constants`).

    Raises
    ------
    RuntimeError
        Without a binary (:func:`available`), or when the constants do not fit the binary's layout.
    """

    def __init__(self, constants):
        if _LIB is None:
            raise RuntimeError(UNAVAILABLE)
        size = _LIB.sideslip_plant_constants_size()
        if len(constants) != size:
            raise RuntimeError(f"the plant kernel takes {size} constants, got {len(constants)}")
        if _LIB.sideslip_plant_io_size() != PLANT_IO:
            raise RuntimeError("the plant kernel's layout is not this module's")
        self._k = (ctypes.c_double * size)(*constants)
        self._io = (ctypes.c_double * PLANT_IO)()
        self._fn = _LIB.sideslip_plant_step

    def step(self, x, dT, inputs, caf: float, car: float, h: float):
        """One communication step.

        Parameters
        ----------
        x : list of float
            The plant's state (:class:`~sideslip.plant.dynamics.St` order).
        dT : float
            The motors' torque difference at the start of the step [N m].
        inputs : tuple of float
            ``delta_f, T_drive, T_brake, Mz_dyc, mu, bank_angle, F_wind_y, M_wind_z`` (SI).
        caf, car : float
            Cornering stiffness of a front and a rear tire on this friction [N/rad].
        h : float
            Communication step [s].

        Returns
        -------
        n : int
            RK4 sub-steps taken.
        x : list of float
            State at the end of the step.
        dT : float
            Torque difference at the end of the step [N m].
        outputs : tuple of float
            Outputs (:data:`sideslip.signals.PLANT_OUTPUTS` order).
        """
        io = self._io
        _PLANT_IN.pack_into(io, 0, *x, dT, *inputs, caf, car, h)     # (struct moves the doubles faster than ctypes)
        n = self._fn(self._k, io)
        state = _STATE.unpack_from(io, 0)
        return n, list(state[:-1]), state[-1], _PLANT_OUT.unpack_from(io, 8 * (PLANT_IO - N_OUTPUTS))


_VEC = ctypes.POINTER(ctypes.c_double)


class DriverPlan(ctypes.Structure):
    """What a driver's compiled steps share: the C ``DriverPlan`` (driver_kernel.c), field for field."""

    _fields_ = [*((name, _VEC) for name in ("x", "y", "s", "ex", "ey", "seg2", "seg", "vlim")),
                ("n", ctypes.c_int), ("closed", ctypes.c_int),
                *((name, ctypes.c_double) for name in (
                    "psi_first", "psi_last", "preview_time", "preview_min", "two_l", "rate", "kp", "ki",
                    "roll_force", "drag", "m", "f_lo", "f_hi", "radius", "brake_only_from", "coast_from",
                    "hold_torque"))]


DRIVER_IO = 16
"""Values of one compiled driver step (driver_kernel.c ``IO_*``)."""
_DRIVER_IN, _DRIVER_OUT = struct.Struct("=13d"), struct.Struct("=7d")


class DriverKernel:
    """The compiled step of one driver: its path and constants, and the buffer the C function reads and writes.

    Parameters
    ----------
    path : sideslip.plant.paths.Path
        The path followed.
    vlim : list of float or None
        Curve speed limit per path sample [m/s].
    constants : dict
        The other :class:`DriverPlan` fields by name.

    Raises
    ------
    RuntimeError
        Without a binary (:func:`available`), or when the binary's layout is not this module's.
    """

    def __init__(self, path, vlim, constants: dict):
        if _LIB is None:
            raise RuntimeError(UNAVAILABLE)
        if (_LIB.sideslip_driver_io_size() != DRIVER_IO
                or _LIB.sideslip_driver_plan_size() != ctypes.sizeof(DriverPlan)):
            raise RuntimeError("the driver kernel's layout is not this module's")
        arrays = {name: (ctypes.c_double * len(values))(*values) for name, values in (
            ("x", path._xl), ("y", path._yl), ("s", path._sl), ("ex", path._ex), ("ey", path._ey),
            ("seg2", path._seg2), ("seg", path._seg), ("vlim", vlim or ()))}
        self._arrays = arrays                       # the plan points into them: kept alive with it
        pointers = {name: ctypes.cast(a, _VEC) if len(a) else None for name, a in arrays.items()}
        self._plan = DriverPlan(**pointers, n=len(path._xl), closed=int(path.closed),
                                psi_first=float(path.psi[0]), psi_last=float(path.psi[-1]), **constants)
        self._ref = ctypes.byref(self._plan)
        self._io = (ctypes.c_double * DRIVER_IO)()
        self._fn = _LIB.sideslip_driver_step

    def step(self, *values):
        """One step: ``h, t, vx, X, Y, yaw, open_loop, target, v_plan, idx, delta, integ, v_prev`` in; returns
        ``(idx, delta, integ, v_prev, T_drive, T_brake, v_ref)`` (driver_kernel.c, ``Driver.step``)."""
        io = self._io
        _DRIVER_IN.pack_into(io, 0, *values)        # (struct moves the doubles faster than ctypes' slices)
        self._fn(self._ref, io)
        return _DRIVER_OUT.unpack_from(io, 9 * 8)


class LqrLaw(ctypes.Structure):
    """What an LQR controller's compiled samples share: the C ``LqrLaw`` (lqr_kernel.c), field for field."""

    _fields_ = [*((name, ctypes.c_int) for name in ("shaped", "valid_gate", "hold_limit", "band", "first")),
                *((name, ctypes.c_double) for name in (
                    "clock_rounding", "v_min", "v_fade", "v_max", "dv", "dmz", "Mz_max", "k_offset", "beta_std_ref",
                    "ramp_rate", "a_beta", "a_gamma", "gravity", "deadband", "k_integral", "bleed", "k_understeer",
                    "understeer_bleed", "Ts", "K_beta",
                    "straight_yaw_rate", "straight_steer", "steer_offset_max", "t_beta_lead", "a_rate",
                    "beta_rate_tau"))]


class LqrDesign(ctypes.Structure):
    """One friction's design for the compiled samples: the C ``LqrDesign`` (lqr_kernel.c), field for field."""

    _fields_ = [("grid", _VEC), ("rows", _VEC), ("n", ctypes.c_int),
                *((name, ctypes.c_double) for name in (
                    "l", "understeer_gradient", "l_r", "m", "l_f", "C_r", "mu", "beta_limit"))]


LQR_IO = 26
"""Values of one compiled controller step (lqr_kernel.c ``IO_*``)."""
_LQR_IN, _LQR_OUT = struct.Struct("=26d"), struct.Struct("=18d")


class LqrKernel:
    """The compiled samples of one LQR controller: its constant law, a compiled design per friction it has used, and
    the buffer the C function reads and writes.

    Parameters
    ----------
    law : dict
        The :class:`LqrLaw` fields by name.

    Raises
    ------
    RuntimeError
        Without a binary (:func:`available`), or when the binary's layout is not this module's.
    """

    def __init__(self, law: dict):
        if _LIB is None:
            raise RuntimeError(UNAVAILABLE)
        if (_LIB.sideslip_lqr_io_size() != LQR_IO or _LIB.sideslip_lqr_law_size() != ctypes.sizeof(LqrLaw)
                or _LIB.sideslip_lqr_design_size() != ctypes.sizeof(LqrDesign)):
            raise RuntimeError("the LQR kernel's layout is not this module's")
        self._law = LqrLaw(**law)
        self._law_ref = ctypes.byref(self._law)
        self._designs: dict = {}            # design friction -> (byref(LqrDesign), the design and arrays it points to)
        self._io = (ctypes.c_double * LQR_IO)()
        self._fn = _LIB.sideslip_lqr_step

    def _design(self, mu: float, model, gains, beta_limit: float):
        grid = (ctypes.c_double * len(gains.grid))(*gains.grid)
        rows = (ctypes.c_double * (2 * len(gains.rows)))(*(g for row in gains.rows for g in row))
        design = LqrDesign(grid=ctypes.cast(grid, _VEC), rows=ctypes.cast(rows, _VEC), n=len(gains.grid),
                           l=model.l, understeer_gradient=model.understeer_gradient, l_r=model.l_r, m=model.m,
                           l_f=model.l_f, C_r=model.C_r, mu=mu, beta_limit=beta_limit)
        entry = self._designs[mu] = (ctypes.byref(design), design, grid, rows)
        return entry

    def step(self, ctl, *values):
        """One communication step of the controller ``ctl`` (its design: ``mu_design``, ``model``, ``gains``,
        ``beta_limit``): the step ``h`` (> 0), the inputs ``delta, vx_hat, beta_hat, yaw_rate, beta_valid, enable,
        beta_std``, the clock ``t, base, n, h_clock`` (NaN before the first step), ``samples_done``, a placeholder
        for the step's samples and the state ``v_schedule, enabled, beta_weight, steer_offset, integral, Mz,
        beta_ref, gamma_ref, Mz_ff, Mz_fb, beta_lowpass, understeer_integral`` in; returns the values from the clock on
        after the step, the step's samples in the placeholder (lqr_kernel.c,
        :meth:`~sideslip.control.base.YawMomentController.step`)."""
        entry = self._designs.get(ctl.mu_design)
        if entry is None:
            entry = self._design(ctl.mu_design, ctl.model, ctl.gains, ctl.beta_limit)
        io = self._io
        _LQR_IN.pack_into(io, 0, *values)           # (struct moves the doubles faster than ctypes' slices)
        self._fn(self._law_ref, entry[0], io)
        return _LQR_OUT.unpack_from(io, 8 * 8)



_FUSION_FUNCTIONS = ("inputs", "kinematic", "wheel", "axles", "heading")
"""The compiled functions of SideslipFusion (fusion_kernel.c), in the order ``sideslip_fusion_io_size`` numbers them."""
FUSION_IO = {"inputs": (12, 12), "kinematic": (16, 3), "wheel": (6, 2), "axles": (21, 10), "heading": (12, 4)}
"""Values in and out of each compiled SideslipFusion function (fusion_kernel.c ``*_SIZE``)."""
_FUSION_IN = {name: struct.Struct(f"={n_in}d") for name, (n_in, _) in FUSION_IO.items()}
_FUSION_OUT = {name: struct.Struct(f"={n_out}d") for name, (_, n_out) in FUSION_IO.items()}
_FUSION_RAISES = {1: (ZeroDivisionError, "float division by zero"), 2: (OverflowError, "math range error"),
                  3: (ValueError, "math domain error")}
"""What the Python reference raises where a C function returns these codes."""

def _raise(code: int):
    error, message = _FUSION_RAISES[code]
    raise error(message)


class FusionKernel:
    """SideslipFusion's compiled scalar models for one estimator: its constants, the buffer the C functions read and
    write, and the arrays they fill (Jacobian rows and the transition matrix, overwritten by the next call).

    Parameters
    ----------
    constants : sequence of float
        The C ``Constants`` struct's values (fusion_kernel.c): the vehicle file's axles
        (:class:`sideslip.estimators.fusion.models.Geometry`), the gravity, the sample period, the utilisation limit,
        1.0 where the undriven wheels are the front ones, the magnetometer's ``mag_norm_gate``,
        ``mag_declination``, ``mag_tilt_std``, ``mag_roll_error``, ``sigma_mag``, ``mag_tilt_correlation_time``,
        ``mag_gate``, and the input conditioner's
        (:meth:`sideslip.estimators.fusion.inputs.InputConditioner.kernel_constants`).
    n : int
        The filter's state size.

    Raises
    ------
    RuntimeError
        Without a binary (:func:`available`), or when the binary's layout is not this module's.
    """

    def __init__(self, constants, n: int):
        import numpy as np

        if _LIB is None:
            raise RuntimeError(UNAVAILABLE)
        if (_LIB.sideslip_fusion_constants_size() != len(constants)
                or any(_LIB.sideslip_fusion_io_size(i) != sum(FUSION_IO[name])
                       for i, name in enumerate(_FUSION_FUNCTIONS))):
            raise RuntimeError("the fusion kernel's layout is not this module's")
        self._args = (tuple(constants), n)
        self._k = (ctypes.c_double * len(constants))(*constants)
        self._io = (ctypes.c_double * max(map(sum, FUSION_IO.values())))()
        self._n = n
        rows = np.zeros((3, n))
        self.rows = (rows[0], rows[1])
        """The front and the rear tire pseudo-measurement's Jacobian row of the last :meth:`axles`."""
        self.wheel_row = rows[2]
        """The wheel-speed measurement's Jacobian row of the last :meth:`wheel`."""
        self.F = np.eye(n)
        """The kinematic model's Jacobian of the last :meth:`kinematic`."""
        self._rows_p = tuple(ctypes.c_void_p(row.ctypes.data) for row in rows)
        self._F_p = ctypes.c_void_p(self.F.ctypes.data)
        self._inputs, self._kinematic, self._wheel, self._axles, self._heading = (
            getattr(_LIB, f"sideslip_fusion_{name}") for name in _FUSION_FUNCTIONS)

    def __reduce__(self):                     # a copy has buffers (and their pointers) of its own
        return FusionKernel, self._args

    def inputs(self, ax: float, ay_m: float, r_m: float, b_ax: float, b_ay: float, k_ay: float, phi: float,
               phi_rate: float, r_prev, r_dot: float, accel: float) -> tuple:
        """A sample's roll-compensated ``a_y``, the axles' ``fy_f, fy_r, fz_f, fz_r, fx_f, fx_r``, then the roll model's
        new ``phi`` and ``phi_rate``, the yaw acceleration, the horizontal acceleration and the log friction floor
        (:class:`sideslip.estimators.fusion.inputs.InputConditioner`; ``r_prev`` None before the first sample)."""
        io = self._io
        _FUSION_IN["inputs"].pack_into(io, 0, ax, ay_m, r_m, b_ax, b_ay, k_ay, phi, phi_rate,
                                       *((0.0, 0.0) if r_prev is None else (r_prev, 1.0)), r_dot, accel)
        code = self._inputs(self._k, io)
        if code:
            _raise(code)
        return _FUSION_OUT["inputs"].unpack_from(io, 8 * 12)

    def kinematic(self, x, ax: float, ay: float, r_m: float) -> tuple:
        """The predicted state and the Jacobian (:attr:`F`) of
        :func:`sideslip.estimators.fusion.models.kinematic_step`."""
        io = self._io
        _FUSION_IN["kinematic"].pack_into(io, 0, *x[:13].tolist(), ax, ay, r_m)
        self._kinematic(self._k, io, self._F_p, self._n)
        xp = x.copy()
        xp[:3] = _FUSION_OUT["kinematic"].unpack_from(io, 8 * 16)
        return xp, self.F

    def wheel(self, vx: float, e_w: float, ln_mu: float, delta: float, v_wheel: float, ax: float) -> tuple:
        """The innovation, the Jacobian row (:attr:`wheel_row`) and the noise variance of
        :func:`sideslip.estimators.fusion.models.wheel_measurement` (the state's ``VX``, ``E_W``, ``LN_MU``, the
        sample's steering, undriven wheels' speed and ``a_x``)."""
        io = self._io
        _FUSION_IN["wheel"].pack_into(io, 0, vx, e_w, ln_mu, delta, v_wheel, ax)
        code = self._wheel(self._k, io, self._rows_p[2], self._n)
        if code:
            _raise(code)
        innovation, variance = _FUSION_OUT["wheel"].unpack_from(io, 8 * 6)
        return innovation, self.wheel_row, variance

    def axles(self, x, inputs) -> tuple:
        """The two axles' ``residual, slip, utilisation, slip_at_max, capacity_slope`` (front, then rear) of the state
        ``x`` and the sample's ``inputs`` (:class:`~sideslip.estimators.fusion.models.SampleInputs`), then their rows
        (:attr:`rows`; :func:`sideslip.estimators.fusion.models.axle_pseudo`)."""
        io = self._io
        _FUSION_IN["axles"].pack_into(io, 0, *x[:10].tolist(), *inputs)
        code = self._axles(self._k, io, *self._rows_p[:2])
        if code:
            _raise(code)
        return _FUSION_OUT["axles"].unpack_from(io, 8 * 21) + self.rows

    def heading(self, *values) -> tuple:
        """What a new magnetometer reading gives (0: nothing; 1: its NIS only; 2: a heading), the heading [rad], its
        variance [rad2] and its NIS, of the reading (x, y, z), the roll model's roll, the state's ``G_Y``, ``PSI``,
        ``B_MAG``, the covariance's ``(G_Y, G_Y)``, ``(PSI, PSI)``, ``(B_MAG, B_MAG)``, ``(PSI, B_MAG)`` and the
        reading's age [samples] (:meth:`sideslip.estimators.fusion.magnetometer.MagnetometerHeading._reading`)."""
        io = self._io
        _FUSION_IN["heading"].pack_into(io, 0, *values)
        code = self._heading(self._k, io)
        if code:
            _raise(code)
        return _FUSION_OUT["heading"].unpack_from(io, 8 * 12)
