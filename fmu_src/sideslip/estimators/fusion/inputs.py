"""The fusion filter's inputs of a sample, from the sensors and the filter's offsets."""
from __future__ import annotations

import math

from ...bicycle import axle_forces
from ...constants import GRAVITY
from ...vehicles import VehicleParams
from ..discrete import lowpass
from ..roll import RollCompensator
from .models import SampleInputs

__all__ = ["InputConditioner"]


class InputConditioner:
    """A sample's :class:`~sideslip.estimators.fusion.models.SampleInputs` from the sensors.

    The lateral acceleration is roll-compensated with the vehicle's roll model (:attr:`roll`); the axle forces
    come from the force and moment balances (:func:`~sideslip.bicycle.axle_forces`) of the lateral acceleration
    less the accelerometer's offset and the roll's gravity the roll model misses (the filter's ``k_ay``) and of
    the low-passed yaw acceleration; the axle loads carry the longitudinal
    load transfer; the axles' longitudinal forces are ``m a_x`` split by the vehicle file's drive or brake split
    (drag and rolling resistance neglected; zero without ``combined_slip``).  It also keeps the friction's floor:
    the road carries at least what the car is measured to do, ``mu >= 0.9 |a| / g`` of the low-passed horizontal
    acceleration (offsets removed).

    Parameters
    ----------
    vehicle : VehicleParams
        The estimator's vehicle.
    ts : float
        Sample period [s].
    yaw_acc_cutoff : float
        Low-pass cut-off of the yaw acceleration [Hz].
    combined_slip : bool
        Split ``m a_x`` over the axles (else no longitudinal forces).
    mu_min, mu_max : float
        Bounds of the friction floor.
    """

    __slots__ = ("vehicle", "ts", "roll", "ln_mu_floor", "compiled", "_cutoff", "_combined", "_mu_min", "_mu_max",
                 "_fz_static", "_r_prev", "_r_dot", "_accel")

    def __init__(self, vehicle: VehicleParams, ts: float, yaw_acc_cutoff: float, combined_slip: bool, mu_min: float,
                 mu_max: float):
        v = vehicle
        self.vehicle, self.ts = v, ts
        self.roll = RollCompensator(v, ts)
        self._cutoff, self._combined, self._mu_min, self._mu_max = yaw_acc_cutoff, combined_slip, mu_min, mu_max
        self._fz_static = (v.m * GRAVITY * v.l_r / v.l, v.m * GRAVITY * v.l_f / v.l)
        self._r_prev = None
        self._r_dot = self._accel = 0.0
        self.ln_mu_floor = math.log(mu_min)
        self.compiled = None
        """The compiled step (:meth:`sideslip.plant.kernel.FusionKernel.inputs`, the same doubles), or None."""

    def kernel_constants(self) -> tuple:
        """The conditioner's constants of the compiled step (fusion_kernel.c ``Constants``, from ``roll_i`` on)."""
        v = self.vehicle
        return (*self.roll.coefficients(), self._cutoff, self._mu_min, self._mu_max, v.m, v.I_zz, v.l_f, v.l_r,
                v.h_cg, float(v.l), *self._fz_static, float(self._combined), v.drive_split_front, v.brake_split_front)

    def __call__(self, ax: float, ay_m: float, r_m: float, delta: float, v_wheel: float, b_ax, b_ay,
                 k_ay: float = 0.0) -> SampleInputs:
        """The inputs of a sample with the measured accelerations [m/s2], yaw rate [rad/s], road-wheel angle [rad] and
        undriven-wheel speed [m/s], and the filter's accelerometer offsets ``b_ax``, ``b_ay`` [m/s2] and roll gain
        ``k_ay``."""
        if self.compiled is not None:
            roll = self.roll
            ay, fyf, fyr, fzf, fzr, fxf, fxr, roll.phi, roll.phi_rate, self._r_dot, self._accel, self.ln_mu_floor = \
                self.compiled(ax, ay_m, r_m, b_ax, b_ay, k_ay, roll.phi, roll.phi_rate, self._r_prev, self._r_dot,
                              self._accel)
            self._r_prev = r_m
            return SampleInputs(ax, ay, r_m, delta, v_wheel, fyf, fyr, fzf, fzr, fxf, fxr)
        v, ts = self.vehicle, self.ts
        ay = self.roll(ay_m)
        b_ay = b_ay + k_ay * ay                     # what is not the tires' force: the offset and the roll's gravity
        if self._r_prev is not None:
            self._r_dot = lowpass(self._r_dot, (r_m - self._r_prev) / ts, ts, self._cutoff)
        self._r_prev = r_m
        a = math.hypot(ax - b_ax, ay - b_ay)
        self._accel = lowpass(self._accel, a, ts, 1.0)
        self.ln_mu_floor = math.log(max(self._mu_min, min(0.9 * self._accel / GRAVITY, self._mu_max)))
        fyf, fyr = axle_forces(v.m, v.I_zz, v.l_f, v.l_r, ay - b_ay, self._r_dot)
        fx = v.m * (ax - b_ax)
        shift = fx * v.h_cg / v.l                                    # longitudinal load transfer
        fzf, fzr = max(self._fz_static[0] - shift, 0.2 * self._fz_static[0]), \
            max(self._fz_static[1] + shift, 0.2 * self._fz_static[1])
        if self._combined:
            front = v.drive_split_front if fx > 0.0 else v.brake_split_front
            fxf, fxr = front * fx, (1.0 - front) * fx
        else:
            fxf = fxr = 0.0
        return SampleInputs(ax, ay, r_m, delta, v_wheel, fyf, fyr, fzf, fzr, fxf, fxr)
