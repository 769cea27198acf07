"""A third-party plant: the CommonRoad multi-body vehicle model, driven through the plant contract.

``vehiclemodels.vehicle_dynamics_mb`` (the CommonRoad project, TU Munich, BSD licence; Althoff,
Koschi, Manzinger, "CommonRoad: Vehicle Models", 2020) is a 29-state multi-body model: the sprung
mass in six degrees of freedom, front and rear unsprung masses with their own roll, lateral and
vertical motion and compliant joints, four wheel spins, PAC2002 Magic Formula tires at combined slip
with camber, and the published parameter sets of three cars (1 Ford Escort, 2 BMW 320i, 3 VW
Vanagon).  Nothing of it was written by this project: :class:`CommonRoadPlant` calls it as it is
and adapts what the project's driver and master give a plant to what the model takes:

* **Steering** - the model's steering angle is a state driven by its rate; here the rate is a
  first-order actuator following the driver's road-wheel angle, ``d(delta)/dt = (delta_f - delta) /
  steer_tau``, within the model's own steering constraints but at ``steer_rate_max`` (the published
  0.4 rad/s is a motion planner's comfort limit, slower than a driver's sine with dwell).
* **Torques** - the model turns one acceleration input into engine and brake torques; here that
  input is zero and the contract's torques enter the wheel equations directly: ``T_drive`` split by
  the set's engine split ``T_se``, ``T_brake`` (>= 0) by its brake split ``T_sb``, each brake torque
  opposing the wheel's spin and faded to zero below ``omega_eps`` (the model forbids a negative spin),
  and the yaw-moment request ``Mz_dyc`` as a left/right torque difference of in-wheel motors on
  ``motor_axle``, ``dT = Mz_dyc R_w / track``, limited to ``motor_T_max`` and lagged by ``motor_tau``
  as on :class:`~sideslip.plant.vehicle.VehiclePlant`.
* **Road** - the friction ``mu`` scales the tires' peak friction (PAC2002's ``lambda_mu``: ``p_dx1``
  and ``p_dy1`` times ``mu``; the slip stiffness is unchanged); a bank ``theta`` (left side up) adds
  gravity's ``-g sin(theta)`` to the lateral and ``g (cos(theta) - 1)`` to the vertical equations of the
  sprung and unsprung masses; the wind's force and moment act on the sprung mass.  The model has no
  aerodynamic drag and no rolling resistance.
* **Speed range** - the model switches to a kinematic single-track form below 0.1 m/s, where the
  contract's torques no longer reach the body, and it has no answer while a wheel's contact point moves
  backward (a full spin): the plant is for driving, and such a state raises a ``ValueError`` naming it
  (the FMU's ``doStep`` returns fmi2Error with that message).  Its tire loads are not clamped when a
  wheel lifts off: beyond the rollover threshold (about ``T / (2 h_cg)``, 1.2 g for the BMW 320i, which
  its PAC2002 tires reach on a dry road) an inner tire pulls at the road and the car rolls over.
* **Integration** - classical RK4 over each communication step with the inputs held, in sub-steps
  chosen from the stiffest wheel-spin mode, ``R^2 p_kx1 F_z / (I_w max(v, 1 m/s))`` plus the brake
  regularisation, so that ``lambda h_sub <= z_max`` (the model's suspension modes are slower than
  1000 1/s).

**Axes** - the model's lateral and yaw equations and its global position read as ISO 8855 and ENU (``v_y``
and a positive yaw rate to the left, the yaw counter-clockwise), but its wheel and roll labels are those of
axes whose ``y`` points right: its "left" wheels are at ``y = -T/2`` (their speed is ``v_x + r T/2``, and a
longitudinal force on them turns the car left) and its roll is positive with the left side down.  The adapter
maps them: the contract's ``fl`` is the model's right front wheel, and its roll is the model's negated.

Outputs are the contract's (:data:`sideslip.signals.PLANT_OUTPUTS`), the truth of the model: the
sprung mass's velocity, yaw rate, roll (plus the bank), the accelerometer's specific force (the
tires' and the wind's force over the mass, rotated by the roll), the wheel spins, the axle lateral
forces and slip angles and the tire loads of the model's tire evaluation (:func:`tire_forces`), and
the yaw moment of the motors' torque difference.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from functools import lru_cache

from ..constants import GRAVITY
from ..model import Model
from ..params import check, param
from ..signals import PLANT_INPUTS, PLANT_OUTPUTS
from ..units import wrap_angle

__all__ = ["VEHICLE_SETS", "CommonRoadConfig", "CommonRoadPlant", "ModelParameters", "vehicle_parameters",
           "tire_forces", "TireForces"]

VEHICLE_SETS = {1: "Ford Escort", 2: "BMW 320i", 3: "VW Vanagon"}
"""The published parameter sets of ``vehiclemodels``, by number."""

N_STATES = 29
_VX, _PSI, _R, _PHI, _VY = 3, 4, 5, 6, 10
_WHEELS = (23, 24, 25, 26)                    # the model's wheel spins, its LF, RF, LR, RR
_ISO_WHEELS = (24, 23, 26, 25)                # the contract's fl, fr, rl, rr (the model's left is ISO's right)
_LATERAL = (10, 15, 20)                        # lateral velocity of the sprung, front and rear unsprung masses
_VERTICAL = (12, 17, 22)                       # their vertical velocity (positive down)


class ModelParameters:
    """The model's parameters as plain attributes (a copy of the package's objects, nested alike, so that the
    model reads them as it reads its own and the FMU state holds only data)."""

    def __init__(self, **values):
        self.__dict__.update(values)


def _plain(obj):
    return ModelParameters(**{k: _plain(v) if hasattr(v, "__dict__") else v for k, v in vars(obj).items()})


@lru_cache(maxsize=None)
def _dynamics():
    """``vehiclemodels.vehicle_dynamics_mb`` (imported on first use; not held by the plant, whose state is data)."""
    from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

    return vehicle_dynamics_mb


@lru_cache(maxsize=None)
def _published(vehicle_set: int) -> ModelParameters:
    from vehiclemodels.vehicle_parameters import setup_vehicle_parameters

    return _plain(setup_vehicle_parameters(vehicle_id=vehicle_set))


def vehicle_parameters(vehicle_set: int, mu: float = 1.0, steer_rate_max: float | None = None) -> ModelParameters:
    """A copy of a published set (:data:`VEHICLE_SETS`) with the tires' peak friction scaled by ``mu`` and, when
    given, the steering rate limit ``steer_rate_max`` [rad/s] (module docstring)."""
    p = copy.deepcopy(_published(vehicle_set))
    p.tire.p_dx1 *= mu
    p.tire.p_dy1 *= mu
    if steer_rate_max is not None:
        p.steering.v_min, p.steering.v_max = -steer_rate_max, steer_rate_max
    return p


@dataclass(frozen=True)
class CommonRoadConfig:
    """Parameters of :class:`CommonRoadPlant` (and of the CommonRoadPlant FMU)."""

    vehicle_set: int = param(2, "Dimensionless", "Published parameter set of vehiclemodels: 1 Ford Escort, "
                             "2 BMW 320i, 3 VW Vanagon", choices=(1, 2, 3))
    vx0: float = param(0.0, "Velocity", "Initial longitudinal speed (wheels rolling freely; at least 0.2: the model "
                       "switches to a kinematic one below 0.1)", ge=0, le=60)
    yaw0: float = param(0.0, "Angle", "Initial yaw angle", ge=-math.pi, le=math.pi)
    X0: float = param(0.0, "Position", "Initial east position", ge=-1e6, le=1e6)
    Y0: float = param(0.0, "Position", "Initial north position", ge=-1e6, le=1e6)
    steer_tau: float = param(0.01, "Time", "Time constant of the steering actuator following delta_f", gt=0, le=1)
    steer_rate_max: float = param(10.0, "AngularVelocity", "Largest road-wheel steering rate", gt=0, le=100)
    omega_eps: float = param(0.5, "AngularVelocity", "Wheel spin below which a brake torque fades to zero",
                             gt=0.01, le=10.0)
    motor_axle: int = param(0, "Dimensionless", "Axle of the in-wheel motors realising Mz_dyc: 0 front, 1 rear",
                            choices=(0, 1))
    motor_T_max: float = param(800.0, "Torque", "Largest torque of one in-wheel motor", ge=0, le=1e4)
    motor_tau: float = param(0.01, "Time", "Time constant of the in-wheel motors' torque", ge=0, le=1)
    z_max: float = param(1.0, "Dimensionless", "Largest stiffness x RK4 sub-step (RK4 is stable below 2.78)",
                         gt=0.01, le=2.5)
    max_substeps: int = param(64, "Dimensionless", "Upper bound of RK4 sub-steps per communication step",
                              ge=1, le=10000)

    def __post_init__(self):
        check(self)


@dataclass(frozen=True)
class TireForces:
    """The model's tire evaluation at a state (:func:`tire_forces`), left front, right front, left rear, right
    rear: vertical loads, longitudinal and lateral forces in wheel axes [N] and slip angles [rad]."""

    fz: tuple
    fx: tuple
    fy: tuple
    alpha: tuple


def tire_forces(x, p: ModelParameters) -> TireForces:
    """The vertical loads, combined-slip forces and slip angles ``vehicle_dynamics_mb`` computes at the state ``x``,
    by the package's own tire functions (``vehiclemodels.utils.tire_model``) on the same slips as the model."""
    import vehiclemodels.utils.tire_model as mf

    delta, vx, r, vy = x[2], x[3], x[5], x[10]
    t_f, t_r, R = p.T_f, p.T_r, p.R_w
    fz = ((x[16] + R * (math.cos(x[13]) - 1) - 0.5 * t_f * math.sin(x[13])) * p.K_zt,
          (x[16] + R * (math.cos(x[13]) - 1) + 0.5 * t_f * math.sin(x[13])) * p.K_zt,
          (x[21] + R * (math.cos(x[18]) - 1) - 0.5 * t_r * math.sin(x[18])) * p.K_zt,
          (x[21] + R * (math.cos(x[18]) - 1) + 0.5 * t_r * math.sin(x[18])) * p.K_zt)
    if abs(vx) < 0.1:                      # the model's kinematic mode: no tire forces
        return TireForces(fz, (0.0,) * 4, (0.0,) * 4, (0.0,) * 4)
    u_w = ((vx + 0.5 * t_f * r) * math.cos(delta) + (vy + p.a * r) * math.sin(delta),
           (vx - 0.5 * t_f * r) * math.cos(delta) + (vy + p.a * r) * math.sin(delta),
           vx + 0.5 * t_r * r, vx - 0.5 * t_r * r)
    slip = tuple(1 - R * x[w] / max(u, 0.0) for w, u in zip(_WHEELS, u_w))
    alpha = (math.atan((vy + p.a * r - x[14] * (R - x[16])) / (vx + 0.5 * t_f * r)) - delta,
             math.atan((vy + p.a * r - x[14] * (R - x[16])) / (vx - 0.5 * t_f * r)) - delta,
             math.atan((vy - p.b * r - x[19] * (R - x[21])) / (vx + 0.5 * t_r * r)),
             math.atan((vy - p.b * r - x[19] * (R - x[21])) / (vx - 0.5 * t_r * r)))
    z = ((p.h_s - R + x[16] - x[11]) / math.cos(x[6]) - p.h_s + R + p.a * x[8] + 0.5 * (x[6] - x[13]) * t_f,
         (p.h_s - R + x[16] - x[11]) / math.cos(x[6]) - p.h_s + R + p.a * x[8] - 0.5 * (x[6] - x[13]) * t_f,
         (p.h_s - R + x[21] - x[11]) / math.cos(x[6]) - p.h_s + R - p.b * x[8] + 0.5 * (x[6] - x[18]) * t_r,
         (p.h_s - R + x[21] - x[11]) / math.cos(x[6]) - p.h_s + R - p.b * x[8] - 0.5 * (x[6] - x[18]) * t_r)
    gamma = (x[6] + p.D_f * z[0] + p.E_f * z[0] ** 2, x[6] - p.D_f * z[1] - p.E_f * z[1] ** 2,
             x[6] + p.D_r * z[2] + p.E_r * z[2] ** 2, x[6] - p.D_r * z[3] - p.E_r * z[3] ** 2)
    fx, fy = [], []
    for s, a, g, f in zip(slip, alpha, gamma, fz):
        fx0 = mf.formula_longitudinal(s, g, f, p.tire)
        fy0, mu_y = mf.formula_lateral(a, g, f, p.tire)
        fx.append(mf.formula_longitudinal_comb(s, a, fx0, p.tire))
        fy.append(mf.formula_lateral_comb(s, a, g, mu_y, f, fy0, p.tire))
    return TireForces(fz, tuple(fx), tuple(fy), alpha)


class CommonRoadPlant(Model):
    """The CommonRoad multi-body vehicle under the plant contract (module docstring).

    Parameters
    ----------
    config : CommonRoadConfig, optional
        Plant parameters (defaults if omitted).

    Notes
    -----
    Call :meth:`step` with the held inputs of a communication step (:data:`sideslip.signals.PLANT_INPUTS`), then
    read :meth:`outputs` (:data:`sideslip.signals.PLANT_OUTPUTS`).
    """

    input_names = PLANT_INPUTS
    output_names = PLANT_OUTPUTS

    def __init__(self, config: CommonRoadConfig | None = None):
        self.config = cfg = config or CommonRoadConfig()
        self.params = p = vehicle_parameters(cfg.vehicle_set, 1.0, cfg.steer_rate_max)
        self._mu = 1.0
        track = p.T_f if cfg.motor_axle == 0 else p.T_r
        self.motor_arm = track / p.R_w                   # Mz = arm dT, dT the right-minus-left torque
        fz_max = max(p.m_s * GRAVITY * p.b / (p.a + p.b) + p.m_uf * GRAVITY,
                     p.m_s * GRAVITY * p.a / (p.a + p.b) + p.m_ur * GRAVITY) / 2.0
        self._wheel_stiffness = p.R_w * p.R_w * p.tire.p_kx1 * fz_max / p.I_y_w
        self.reset()

    def reset(self) -> None:
        """Back to the initial condition (rolling freely and straight at ``vx0``, the model's static deflections)."""
        from vehiclemodels.init_mb import init_mb

        cfg = self.config
        self.x = [float(v) for v in init_mb([cfg.X0, cfg.Y0, 0.0, cfg.vx0, cfg.yaw0, 0.0, 0.0], self.params)]
        self._reset_clock()
        self.dT_motor = 0.0
        self.n_substeps = 1
        self._u = (0.0,) * len(PLANT_INPUTS)
        self._out = self._outputs_at(self.x)

    # ------------------------------------------------------------------ dynamics
    def _set_friction(self, mu: float) -> None:
        if mu != self._mu:
            self.params = vehicle_parameters(self.config.vehicle_set, mu, self.config.steer_rate_max)
            self._mu = mu

    def derivative(self, x, u, dT: float) -> list:
        """The state derivative at ``x`` with the held contract inputs ``u`` (:data:`PLANT_INPUTS` order) and the
        motors' torque difference ``dT`` [N m]: the model's, plus the adapter's torques, bank and wind."""
        cfg, p = self.config, self.params
        delta_f, T_drive, T_brake, _, _, bank, f_wind, m_wind = u
        try:
            f = _dynamics()(list(x), [(delta_f - x[2]) / cfg.steer_tau, 0.0], p)
        except ZeroDivisionError:
            raise ValueError("the CommonRoad model has no answer at this state: a wheel's contact point stands "
                             f"still or moves backward (v_x = {x[3]:.3g} m/s, yaw rate {x[5]:.3g} rad/s; a stop or a "
                             "spin)") from None
        tb = T_brake if T_brake > 0.0 else 0.0
        eps, half = cfg.omega_eps, 0.5 * dT
        front, rear = (half, 0.0) if cfg.motor_axle == 0 else (0.0, half)
        drive_f, drive_r = 0.5 * p.T_se * T_drive, 0.5 * (1.0 - p.T_se) * T_drive
        brake_f, brake_r = 0.5 * p.T_sb * tb, 0.5 * (1.0 - p.T_sb) * tb
        # the model's LF, RF, LR, RR; its left wheels are ISO 8855's right ones (module docstring): a positive dT
        # drives them
        torques = (drive_f - brake_f * _fade(x[23], eps) + front, drive_f - brake_f * _fade(x[24], eps) - front,
                   drive_r - brake_r * _fade(x[25], eps) + rear, drive_r - brake_r * _fade(x[26], eps) - rear)
        for i, tq in zip(_WHEELS, torques):
            f[i] += tq / p.I_y_w
            if x[i] <= 0.0 and f[i] < 0.0:               # the model forbids a negative spin
                f[i] = 0.0
        if bank:
            g_lat, g_vert = GRAVITY * math.sin(bank), GRAVITY * (math.cos(bank) - 1.0)
            for i in _LATERAL:
                f[i] -= g_lat
            for i in _VERTICAL:
                f[i] += g_vert
        if f_wind or m_wind:
            f[_VY] += f_wind / p.m_s
            f[_R] += m_wind / p.I_z
        return f

    def _substeps(self, h: float, tb: float) -> int:
        cfg = self.config
        speed = abs(self.x[_VX])
        stiff = self._wheel_stiffness / (speed if speed > 1.0 else 1.0) + tb / (self.params.I_y_w * cfg.omega_eps)
        n = int(math.ceil(h * stiff / cfg.z_max - 1e-12))
        return n if 1 <= n <= cfg.max_substeps else (1 if n < 1 else cfg.max_substeps)

    def step(self, h: float, delta_f: float = 0.0, T_drive: float = 0.0, T_brake: float = 0.0, Mz_dyc: float = 0.0,
             mu: float = 1.0, bank_angle: float = 0.0, F_wind_y: float = 0.0, M_wind_z: float = 0.0) -> None:
        """Advance by one communication step ``h`` [s] with the inputs held over it.

        Raises
        ------
        ValueError
            If an input is not finite or ``h <= 0``.
        """
        if not math.isfinite(delta_f + T_drive + T_brake + Mz_dyc + mu + bank_angle + F_wind_y + M_wind_z):
            raise ValueError("plant inputs must be finite")
        self._tick(h)
        cfg = self.config
        self._set_friction(mu if mu > 0.01 else 0.01)
        self._u = u = (delta_f, T_drive, T_brake, Mz_dyc, mu, bank_angle, F_wind_y, M_wind_z)
        lim = cfg.motor_T_max
        dT_cmd = min(max(Mz_dyc / self.motor_arm, -lim), lim)
        n = self._substeps(h, T_brake if T_brake > 0.0 else 0.0)
        self.n_substeps = n
        hs = h / n
        half, h6 = 0.5 * hs, hs / 6.0
        decay = math.exp(-half / cfg.motor_tau) if cfg.motor_tau > 0.0 else 0.0
        x, dT, f = self.x, self.dT_motor, self.derivative
        for _ in range(n):
            dT_mid = dT_cmd + (dT - dT_cmd) * decay
            dT_end = dT_cmd + (dT_mid - dT_cmd) * decay
            k1 = f(x, u, dT)
            k2 = f([a + half * b for a, b in zip(x, k1)], u, dT_mid)
            k3 = f([a + half * b for a, b in zip(x, k2)], u, dT_mid)
            k4 = f([a + hs * b for a, b in zip(x, k3)], u, dT_end)
            x = [a + h6 * (b1 + 2.0 * (b2 + b3) + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
            for i in _WHEELS:                             # as the model does: no negative spin
                if x[i] < 0.0:
                    x[i] = 0.0
            dT = dT_end
        x[_PSI] = wrap_angle(x[_PSI])
        self.x, self.dT_motor = x, dT
        self._out = self._outputs_at(x)

    # ------------------------------------------------------------------ outputs
    def _outputs_at(self, x) -> tuple:
        p = self.params
        delta_f, T_drive, T_brake, _, _, bank, f_wind, m_wind = self._u
        f = _dynamics()(list(x), [0.0, 0.0], p)
        vx, r, vy, phi = x[_VX], x[_R], x[_VY], -x[_PHI]          # ISO 8855 roll: the model's is the mirror
        # specific force: the tires' (and the wind's) force over the mass; the internal suspension forces cancel
        # in the sum of the three bodies' lateral equations
        ay_road = (p.m_s * (f[10] + r * vx) + p.m_uf * (f[15] + r * vx) + p.m_ur * (f[20] + r * vx) + f_wind) / p.m
        ax_spec = f[_VX] - r * vy
        ay_body = math.cos(phi) * ay_road + math.sin(phi) * GRAVITY * math.cos(bank)
        t = tire_forces(x, p)
        cd, sd = math.cos(x[2]), math.sin(x[2])
        fy_f = (t.fy[0] + t.fy[1]) * cd + (t.fx[0] + t.fx[1]) * sd
        fy_r = t.fy[2] + t.fy[3]
        fz = t.fz
        return (vx, vy, r, math.atan2(vy, vx), wrap_angle(x[_PSI]), bank + phi, -x[7], ax_spec, ay_body,
                x[0], x[1], *(x[i] for i in _ISO_WHEELS), fy_f, fy_r, fz[1], fz[0], fz[3], fz[2],
                0.5 * (t.alpha[0] + t.alpha[1]), 0.5 * (t.alpha[2] + t.alpha[3]), self.motor_arm * self.dT_motor)


def _fade(omega: float, eps: float) -> float:
    """A brake torque's share at the wheel spin ``omega``: 1 above ``eps``, to 0 at a standstill."""
    return 1.0 if omega >= eps else (omega / eps if omega > 0.0 else 0.0)
