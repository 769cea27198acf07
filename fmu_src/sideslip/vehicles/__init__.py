"""Vehicle parameter sets: a validated, frozen dataclass in SI units and one TOML per vehicle.

Each TOML file holds ``[params]`` (the :class:`VehicleParams` fields) and ``[source]``
(the paper and table, plus an ``assumed`` table giving the reason for every value that
the paper does not provide).  Load with :func:`load_vehicle` by name or path; override
single values with ``"m=2000, I_zz=3800"``.  Every model configuration that takes a vehicle
inherits :class:`VehicleConfig` (the parameter pair ``vehicle`` / ``vehicle_overrides``).

A user's file must give every parameter, or name a vehicle to inherit the rest from with a
top-level ``base = "pi2011_suv"`` (a bundled name, or a file path relative to it): a file with a
few keys is refused naming the missing ones, not silently completed with defaults.  The bundled
files are read when the module is imported, so an FMU keeps them when its host deletes its
unpacked folder.
"""
from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from ..constants import GRAVITY
from ..params import (ParameterError, ParamGroup, build, check, did_you_mean, format_assignments, param,
                      parse_assignments)
from ..plant.tires import MagicFormula

__all__ = ["VehicleParams", "VehicleConfig", "load_vehicle", "vehicle_names", "vehicle_source", "resolve_vehicle",
           "DERIVED", "derived"]

_DIR = Path(__file__).parent


@dataclass(frozen=True)
class VehicleParams:
    """Physical parameters of one vehicle (SI units, per-tire unless stated per axle).

    The plant uses the physical values; estimators use the ``*_nominal`` axle cornering
    stiffnesses (what a paper's filter assumes), which may differ from the plant's tires
    on purpose (e.g. Nguyen 2012: true 10000, nominal 7000 N/rad per tire).
    """

    name: str = param("custom", "Dimensionless", "Vehicle name", fmu=False)
    # masses and inertias
    m: float = param(1500.0, "Mass", "Total vehicle mass", gt=0, le=1e5)
    m_s: float = param(1350.0, "Mass", "Sprung mass", gt=0, le=1e5)
    m_uf: float = param(75.0, "Mass", "Front unsprung mass (axle)", ge=0, le=1e4)
    m_ur: float = param(75.0, "Mass", "Rear unsprung mass (axle)", ge=0, le=1e4)
    I_zz: float = param(2500.0, "MomentOfInertia", "Yaw moment of inertia", gt=0, le=1e6)
    I_xx: float = param(500.0, "MomentOfInertia", "Roll moment of inertia of the sprung mass about its CG",
                         gt=0, le=1e6)
    I_xz: float = param(0.0, "MomentOfInertia", "Yaw/roll product of inertia of the sprung mass", ge=-1e5, le=1e5)
    # geometry
    l_f: float = param(1.2, "Length", "CG to front axle", gt=0, le=10)
    l_r: float = param(1.5, "Length", "CG to rear axle", gt=0, le=10)
    l_fs: float = param(1.2, "Length", "Sprung-mass CG to front axle", gt=0, le=10)
    l_rs: float = param(1.5, "Length", "Sprung-mass CG to rear axle", gt=0, le=10)
    t_f: float = param(1.55, "Length", "Front track width", gt=0, le=5)
    t_r: float = param(1.55, "Length", "Rear track width", gt=0, le=5)
    h_cg: float = param(0.55, "Length", "Height of the vehicle CG", gt=0, le=5)
    h_s: float = param(0.45, "Length", "Sprung-mass CG above the roll axis", ge=0, le=5)
    h_uf: float = param(0.3, "Length", "Height of the front unsprung-mass CG", ge=0, le=5)
    h_ur: float = param(0.3, "Length", "Height of the rear unsprung-mass CG", ge=0, le=5)
    # suspension
    K_phi_f: float = param(60000.0, "RollStiffness", "Front roll stiffness", gt=0, le=1e7)
    K_phi_r: float = param(45000.0, "RollStiffness", "Rear roll stiffness", gt=0, le=1e7)
    C_phi_f: float = param(4000.0, "RollDamping", "Front roll damping", ge=0, le=1e6)
    C_phi_r: float = param(3000.0, "RollDamping", "Rear roll damping", ge=0, le=1e6)
    # wheels and tires
    R_w: float = param(0.31, "Length", "Effective rolling radius", gt=0, le=2)
    I_w: float = param(1.2, "MomentOfInertia", "Spin inertia of one wheel (incl. driveline share)", gt=0, le=100)
    C_sigma: float = param(90000.0, "Force", "Tire longitudinal slip stiffness (per tire, N per unit slip)",
                           gt=0, le=1e7)
    C_alpha_f: float = param(60000.0, "CorneringStiffness", "Front tire cornering stiffness at mu >= 1",
                             gt=0, le=1e7)
    C_alpha_r: float = param(60000.0, "CorneringStiffness", "Rear tire cornering stiffness at mu >= 1",
                             gt=0, le=1e7)
    mu_lo: float = param(0.3, "FrictionCoefficient", "Friction at which the *_lo cornering stiffnesses hold",
                         gt=0, lt=1)
    C_alpha_f_lo: float = param(60000.0, "CorneringStiffness",
                                "Front tire cornering stiffness at mu = mu_lo (linear in mu between)", gt=0, le=1e7)
    C_alpha_r_lo: float = param(60000.0, "CorneringStiffness",
                                "Rear tire cornering stiffness at mu = mu_lo (linear in mu between)", gt=0, le=1e7)
    eps_v: float = param(0.0, "Slowness", "Dugoff velocity effect factor (friction drop per sliding speed)",
                         ge=0, le=0.2)
    # Magic Formula 5.2 subset (sideslip.plant.tires; the plant's tire_model 1): shape, peak, combined slip
    mf_pCx1: float = param(1.6, "Dimensionless", "Magic Formula: longitudinal shape factor C_x", gt=1, lt=2)
    mf_pDx1: float = param(1.0, "Dimensionless", "Magic Formula: longitudinal friction at the nominal load (x mu)",
                           gt=0, le=2)
    mf_pDx2: float = param(-0.08, "Dimensionless", "Magic Formula: variation of the longitudinal friction with load",
                           ge=-0.5, le=0.5)
    mf_pEx1: float = param(0.3, "Dimensionless", "Magic Formula: longitudinal curvature E_x", ge=-5, lt=1)
    mf_pCy1: float = param(1.3, "Dimensionless", "Magic Formula: lateral shape factor C_y", gt=1, lt=2)
    mf_pDy1: float = param(1.0, "Dimensionless", "Magic Formula: lateral friction at the nominal load (x mu)",
                           gt=0, le=2)
    mf_pDy2: float = param(-0.1, "Dimensionless", "Magic Formula: variation of the lateral friction with load",
                           ge=-0.5, le=0.5)
    mf_pEy1: float = param(-0.8, "Dimensionless", "Magic Formula: lateral curvature E_y", ge=-5, lt=1)
    mf_pKy2: float = param(1.7, "Dimensionless", "Magic Formula: load (x nominal) of the cornering-stiffness peak",
                           gt=0.5, le=5)
    mf_rBx1: float = param(12.0, "Dimensionless", "Magic Formula: combined slip, Fx reduction slope", gt=0, le=50)
    mf_rBx2: float = param(10.0, "Dimensionless", "Magic Formula: combined slip, its variation with kappa",
                           ge=0, le=50)
    mf_rCx1: float = param(1.08, "Dimensionless", "Magic Formula: combined slip, Fx reduction shape", gt=0, le=2)
    mf_rBy1: float = param(8.0, "Dimensionless", "Magic Formula: combined slip, Fy reduction slope", gt=0, le=50)
    mf_rBy2: float = param(7.0, "Dimensionless", "Magic Formula: combined slip, its variation with alpha",
                           ge=0, le=50)
    mf_rCy1: float = param(1.05, "Dimensionless", "Magic Formula: combined slip, Fy reduction shape", gt=0, le=2)
    # estimator-side nominal values (axle)
    C_f_nominal: float = param(120000.0, "CorneringStiffness", "Nominal front-axle cornering stiffness at mu ~ 1 "
                               "(what the papers' filters assume)", gt=0, le=2e7)
    C_r_nominal: float = param(120000.0, "CorneringStiffness", "Nominal rear-axle cornering stiffness at mu ~ 1",
                               gt=0, le=2e7)
    C_f_nominal_lo: float = param(120000.0, "CorneringStiffness", "Nominal front-axle cornering stiffness at "
                                  "mu = mu_lo", gt=0, le=2e7)
    C_r_nominal_lo: float = param(120000.0, "CorneringStiffness", "Nominal rear-axle cornering stiffness at "
                                  "mu = mu_lo", gt=0, le=2e7)
    # drivetrain, brakes, in-wheel motors
    steering_ratio: float = param(15.0, "Dimensionless", "Handwheel angle / road-wheel angle", gt=1, le=40)
    drive_split_front: float = param(1.0, "Dimensionless", "Share of drive torque on the front axle", ge=0, le=1)
    brake_split_front: float = param(0.65, "Dimensionless", "Share of brake torque on the front axle",
                                     ge=0, le=1)
    motor_axle: str = param("rear", "Dimensionless", "Axle carrying the in-wheel motors that realise Mz_dyc",
                            choices=("front", "rear"))
    motor_T_max: float = param(800.0, "Torque", "Torque limit of one in-wheel motor", ge=0, le=1e5)
    motor_tau: float = param(0.01, "Time", "Time constant of the in-wheel motor torque response", ge=0, le=1)
    # resistances
    f_rr: float = param(0.012, "Dimensionless", "Rolling-resistance coefficient", ge=0, le=0.1)
    CdA: float = param(0.7, "Area", "Aerodynamic drag area", ge=0, le=50)
    rho_air: float = param(1.2, "Density", "Air density", gt=0, le=5)

    def __post_init__(self):
        check(self, prefix="vehicle.")
        if abs(self.m_s + self.m_uf + self.m_ur - self.m) > 0.02 * self.m:
            raise ParameterError("vehicle.m_s", self.m_s,
                                 f"m_s + m_uf + m_ur within 2 % of m = {self.m:g} kg")
        if self.h_scg < self.h_s:
            raise ParameterError("vehicle.h_s", self.h_s,
                                 f"<= sprung CG height {self.h_scg:.3f} m (roll axis above ground)")
        if self.K_phi_f + self.K_phi_r <= self.m_s * GRAVITY * self.h_s:
            raise ParameterError("vehicle.K_phi_f", self.K_phi_f,
                                 f"K_phi_f + K_phi_r > m_s g h_s = {self.m_s * GRAVITY * self.h_s:.0f} N.m/rad "
                                 "(statically stable roll)")
        if self.I_xz ** 2 >= self.I_zz * self.I_roll:
            raise ParameterError("vehicle.I_xz", self.I_xz, "I_xz^2 < I_zz (I_xx + m_s h_s^2)")

    # ---- derived quantities ------------------------------------------------------------
    @property
    def l(self) -> float:
        """Wheelbase l_f + l_r [m]."""
        return self.l_f + self.l_r

    @property
    def h_scg(self) -> float:
        """Height of the sprung-mass CG [m]."""
        return (self.m * self.h_cg - self.m_uf * self.h_uf - self.m_ur * self.h_ur) / self.m_s

    @property
    def h_roll_axis(self) -> float:
        """Height of the (horizontal) roll axis [m]."""
        return self.h_scg - self.h_s

    @property
    def I_roll(self) -> float:
        """Sprung-mass roll inertia about the roll axis, I_xx + m_s h_s^2 [kg m2]."""
        return self.I_xx + self.m_s * self.h_s ** 2

    @property
    def C_f(self) -> float:
        """True front-axle cornering stiffness at mu >= 1 [N/rad]."""
        return 2.0 * self.C_alpha_f

    @property
    def C_r(self) -> float:
        """True rear-axle cornering stiffness at mu >= 1 [N/rad]."""
        return 2.0 * self.C_alpha_r

    def cornering_stiffness(self, mu: float) -> tuple[float, float]:
        """Per-tire cornering stiffness (front, rear) [N/rad] on friction ``mu``.

        Linear in ``mu`` between ``mu_lo`` and 1, held outside: tires on snow are softer in
        their linear range, not only lower in their limit (Park 2018, Table 1).
        """
        w = min(max((mu - self.mu_lo) / (1.0 - self.mu_lo), 0.0), 1.0)
        return (self.C_alpha_f_lo + w * (self.C_alpha_f - self.C_alpha_f_lo),
                self.C_alpha_r_lo + w * (self.C_alpha_r - self.C_alpha_r_lo))

    def nominal_cornering_stiffness(self, mu: float = 1.0) -> tuple[float, float]:
        """Estimator-side axle cornering stiffness (front, rear) [N/rad] for friction ``mu``.

        Interpolated like :meth:`cornering_stiffness` (Park 2018 keeps C_f0n/C_r0n per mu).
        """
        w = min(max((mu - self.mu_lo) / (1.0 - self.mu_lo), 0.0), 1.0)
        return (self.C_f_nominal_lo + w * (self.C_f_nominal - self.C_f_nominal_lo),
                self.C_r_nominal_lo + w * (self.C_r_nominal - self.C_r_nominal_lo))

    def static_wheel_load(self, axle: str) -> float:
        """Load of one wheel of the ``"front"`` or ``"rear"`` axle at rest on a flat road [N]."""
        share = self.l_r if axle == "front" else self.l_f
        return self.m * GRAVITY * share / (2.0 * self.l)

    def magic_formula(self, axle: str):
        """Magic Formula coefficients of a tire of the ``"front"`` or ``"rear"`` axle, its nominal load
        the static wheel load (so that both tire models have the vehicle's stiffness there)."""
        return MagicFormula(self.static_wheel_load(axle), *(getattr(self, f"mf_{name}")
                                                            for name in MagicFormula._fields[1:]))

    def with_overrides(self, overrides: str | dict) -> "VehicleParams":
        """A copy with some fields replaced (``"m=2000, I_zz=3800"`` or a mapping), validated."""
        items = parse_assignments(overrides, "vehicle_overrides") if isinstance(overrides, str) else dict(overrides)
        if not items:
            return self
        return build(VehicleParams, derived(dataclasses.asdict(self), items), prefix="vehicle.")


DERIVED = {"m_s": "m - m_uf - m_ur", "l_fs": "l_f + (l_fs - l_f) of the base", "l_rs": "l_r + (l_rs - l_r) of the base"}
"""Values that follow the ones they derive from when a file with a ``base`` (or an override) changes those and
does not give them: the sprung mass follows the total mass (the unsprung masses kept), the sprung-mass CG keeps its
distance from the vehicle's CG."""


def derived(base: dict, given: dict) -> dict:
    """``base`` updated by ``given``, with the :data:`DERIVED` values ``given`` leaves out following what it changes."""
    out = {**base, **given}
    if "m" in given and "m_s" not in given and "m_s" in base:
        out["m_s"] = float(out["m"]) - float(out["m_uf"]) - float(out["m_ur"])
    for axle in ("f", "r"):
        if f"l_{axle}" in given and f"l_{axle}s" not in given and f"l_{axle}s" in base:
            out[f"l_{axle}s"] = float(out[f"l_{axle}"]) + float(base[f"l_{axle}s"]) - float(base[f"l_{axle}"])
    return out


def _parse(text: str, where: str) -> dict:
    """A vehicle file's tables; a file that is not TOML or has no ``[params]`` names the file and why."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError("vehicle", where, f"a TOML file ({exc})") from None
    if not isinstance(data.get("params"), dict):
        raise ParameterError("vehicle", where, "a TOML file with a [params] table")
    return data


_BUNDLED: dict[str, dict] = {p.stem: _parse(p.read_text(), str(p)) for p in sorted(_DIR.glob("*.toml"))}
"""The bundled vehicle files by name, read at import (see module docstring)."""

_REQUIRED = tuple(f.name for f in dataclasses.fields(VehicleParams) if f.name != "name")


def vehicle_names() -> list[str]:
    """Names of the bundled vehicle parameter sets."""
    return sorted(_BUNDLED)


def _load_file(name_or_path: str, _chain: tuple = ()) -> tuple[str, dict, dict]:
    """``(name, params, source)`` of a bundled name or a TOML path, a ``base`` merged in (cached while the file
    is unchanged: an edited file is read again)."""
    try:
        stat = Path(name_or_path).stat() if name_or_path not in _BUNDLED else None
    except OSError:
        stat = None
    return _load_cached(name_or_path, _chain, (stat.st_mtime_ns, stat.st_size) if stat else None)


@lru_cache(maxsize=32)
def _load_cached(name_or_path: str, _chain: tuple, _version) -> tuple[str, dict, dict]:
    if name_or_path in _BUNDLED:
        data, name, folder = _BUNDLED[name_or_path], name_or_path, _DIR
    else:
        path = Path(name_or_path)
        if path.suffix != ".toml" or not path.is_file():
            raise ParameterError("vehicle", name_or_path,
                                 "one of " + ", ".join(vehicle_names()) + did_you_mean(name_or_path, vehicle_names())
                                 + " or the path of a vehicle TOML file" + ("" if path.suffix != ".toml" else
                                                                            f" ({path} does not exist)"))
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ParameterError("vehicle", name_or_path, f"a readable TOML file ({exc})") from None
        data, name, folder = _parse(text, name_or_path), path.stem, path.parent
    params = dict(data["params"])
    base = data.get("base")
    if base is not None:
        if not isinstance(base, str) or base in _chain + (name_or_path,):
            raise ParameterError("vehicle", name_or_path, "a 'base' naming another vehicle (no cycle)")
        resolved = base if base in _BUNDLED else str(folder / base)
        params = derived(_load_file(resolved, _chain + (name_or_path,))[1], params)
    return name, params, data.get("source", {})


def load_vehicle(name_or_path: str, overrides: str | dict = "") -> VehicleParams:
    """Load a vehicle by bundled name or TOML path and apply overrides.

    Raises
    ------
    ParameterError
        Unknown vehicle, a file that cannot be read or parsed, missing parameters (without a
        ``base``), an unknown field, or a value outside its allowed range; the message names the
        file or the parameter.
    """
    name, params, _ = _load_file(name_or_path)
    missing = [k for k in _REQUIRED if k not in params]
    if missing:
        raise ParameterError("vehicle", name_or_path,
                             f"a [params] table with every vehicle parameter; missing: {', '.join(missing)} "
                             "(or a top-level base = \"<bundled vehicle or file>\" to inherit them)")
    vehicle = build(VehicleParams, {"name": name, **params}, prefix="vehicle.")
    return vehicle.with_overrides(overrides)


def resolve_vehicle(name_or_path: str) -> tuple[VehicleParams, dict]:
    """The vehicle of a name or file and where each value came from.

    Returns
    -------
    VehicleParams, dict
        The validated vehicle (as :func:`load_vehicle`) and ``{field: origin}``, the origin one of
        ``"file <path>"``, ``"base <name>"`` (inherited, through every level) or ``"derived: <rule>"``.

    Raises
    ------
    ParameterError
        As :func:`load_vehicle`.
    """
    vehicle = load_vehicle(name_or_path)
    return vehicle, _origins(name_or_path)


def _origins(name_or_path: str) -> dict:
    if name_or_path in _BUNDLED:
        data, folder, label = _BUNDLED[name_or_path], _DIR, f"bundled {name_or_path}"
    else:
        path = Path(name_or_path)
        data, folder, label = _parse(path.read_text(encoding="utf-8"), name_or_path), path.parent, f"file {path}"
    own = {k: label for k in data["params"]}
    base = data.get("base")
    if base is None:
        return own
    inherited = _origins(base if base in _BUNDLED else str(folder / base))
    for name, rule in DERIVED.items():
        source = "m" if name == "m_s" else name[:3]
        if source in own and name not in own:
            own[name] = f"derived: {rule}"
    return {**{k: (v if v.startswith("derived") else f"base {base}") for k, v in inherited.items()}, **own}


def vehicle_source(name_or_path: str) -> dict:
    """The ``[source]`` table of a vehicle file (paper, table, assumed values with reasons; a key of
    ``assumed`` may be a glob pattern naming a group, e.g. ``"mf_*"``)."""
    return dict(_load_file(name_or_path)[2])


@dataclass(frozen=True)
class VehicleConfig:
    """The vehicle of a model configuration: a parameter set and overrides of single values.

    Every config of a model that takes a vehicle (plant, driver, estimators, controllers)
    inherits these two fields first; a subclass may redeclare ``vehicle`` with another default.
    """

    vehicle: str = param("pi2011_suv", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    vehicle_overrides: str = param("", "Dimensionless", "Vehicle parameter overrides, e.g. 'm=2000, I_zz=3800'")

    def vehicle_params(self) -> VehicleParams:
        """The configured vehicle, loaded and validated (see :func:`load_vehicle`)."""
        return load_vehicle(self.vehicle, self.vehicle_overrides)

    STRING_STAND_INS = ("vehicle", "vehicle_overrides")
    """The String fields :meth:`numeric_parameters` expresses in numbers."""

    @classmethod
    def parameter_groups(cls) -> tuple[ParamGroup, ...]:
        """The vehicle's values as numeric parameters ``vehicle.<field>`` (for hosts that cannot set
        Strings), their start values the class's default vehicle's."""
        default = cls.__dataclass_fields__["vehicle"].default
        return (ParamGroup("vehicle", VehicleParams, dataclasses.asdict(load_vehicle(default))),)

    def with_parameter_groups(self, values: dict) -> "VehicleConfig":
        """This configuration with the numeric parameters of :meth:`parameter_groups` applied.

        Precedence, lowest first: the vehicle file named by ``vehicle``; each numeric parameter
        ``vehicle.<field>`` whose value differs from its start value (a host that writes every start
        value back changes nothing); ``vehicle_overrides``.

        Raises
        ------
        ParameterError
            For a numeric value outside its range (named ``vehicle.<field>``).
        """
        changed = self.parameter_groups()[0].changed(values)
        if not changed:
            return self
        merged = {**changed, **parse_assignments(self.vehicle_overrides, "vehicle_overrides")}
        return dataclasses.replace(self, vehicle_overrides=format_assignments(merged))

    def numeric_parameters(self) -> dict:
        """The numeric parameters that configure this vehicle without Strings (every ``vehicle.<field>``)."""
        return self.parameter_groups()[0].numbers(self.vehicle_params())
