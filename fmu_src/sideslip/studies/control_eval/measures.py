"""What a closed loop is scored by: the FMVSS 126 criteria and tracking, effort and smoothness."""
from __future__ import annotations

import math

import numpy as np

from ...bicycle import BicycleModel
from ...control.base import yaw_moment_limit
from ...control.reference import ReferenceModel
from ...units import DEG
from ...vehicles import VehicleParams
from ..metrics import rms

MEASURES = ("max_abs_beta_deg", "rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "saturated_pct",
            "rms_Mz_cmd", "rms_dMz_dt", "max_dMz_dt", "max_counter_Mz_launch")
"""The metrics of every run (:func:`control_metrics`), averaged over seeds and maneuvers."""
REFERENCE_LAGS = (0.15, 0.10)
"""[s] ``tau_beta``, ``tau_gamma`` of the evaluation's reference model: fixed, so that a controller's own lags
(which its tuning changes) do not move the yardstick every row is measured against."""


def fmvss126_metrics(a: dict, t_bos: float, t_cos: float, factor: float, frequency: float = 0.7) -> dict:
    """FMVSS 126 yaw-stability and responsiveness measures of one sine-with-dwell run.

    Parameters
    ----------
    a : dict
        Arrays ``time``, ``plant.yaw_rate``, ``plant.X``, ``plant.Y``, ``plant.yaw``,
        ``driver.delta_sw``.
    t_bos, t_cos : float
        Beginning and completion of steer [s].
    factor : float
        Amplitude in multiples of A (the displacement criterion applies from 5A).
    frequency : float
        Frequency of the sine [Hz] (0.7 in S7.7).
    """
    t, r, dsw = a["time"], a["plant.yaw_rate"], a["driver.delta_sw"]
    i_bos, i_cos = np.searchsorted(t, t_bos), np.searchsorted(t, t_cos)
    # direction of the first half-wave: handwheel at its first peak (a quarter period after the
    # beginning of steer) against the handwheel at the beginning (the driver may hold a small trim)
    first = np.sign(np.interp(t_bos + 0.25 / frequency, t, dsw) - np.interp(t_bos, t, dsw))
    i_rev = i_bos + int(np.argmax(np.sign(dsw[i_bos:i_cos]) == -first))   # steering wheel changes sign
    window = r[i_rev:i_cos + 1]
    peak = float(window[np.argmax(np.abs(window))])
    r100 = float(np.interp(t_cos + 1.00, t, r)) / peak
    r175 = float(np.interp(t_cos + 1.75, t, r)) / peak
    x0, y0, yaw0 = (float(np.interp(t_bos, t, a[k])) for k in ("plant.X", "plant.Y", "plant.yaw"))
    x1, y1 = (float(np.interp(t_bos + 1.07, t, a[k])) for k in ("plant.X", "plant.Y"))
    lateral = first * (-(x1 - x0) * math.sin(yaw0) + (y1 - y0) * math.cos(yaw0))
    yaw_ok = r100 < 0.35 and r175 < 0.20
    lat_ok = lateral >= 1.83 or factor < 5.0
    return {"yaw_rate_ratio_1s": r100, "yaw_rate_ratio_1p75s": r175, "lateral_1p07s": float(lateral),
            "yaw_stable": bool(yaw_ok), "responsive": bool(lat_ok), "pass": bool(yaw_ok and lat_ok)}


def control_metrics(a: dict, vehicle: VehicleParams, mu: float, Mz_max: float | None = None, v_min: float = 5.0,
                    Ts: float = 1e-3) -> dict:
    """Tracking, effort and smoothness of one run.

    Parameters
    ----------
    a : dict
        Arrays ``time``, ``plant.{vx,beta,yaw_rate,Mz_act}``, ``driver.delta_f`` and, with a
        controller, ``controller.Mz_cmd``.
    vehicle : VehicleParams
        The plant's vehicle (the reference model's; the motors' limit).
    mu : float
        Friction of the reference model.
    Mz_max : float, optional
        The controller's limit (default: the vehicle's motors).

    Returns
    -------
    dict
        ``max_abs_beta_deg``, ``rms_yaw_rate_error_deg_s``, ``rms_beta_error_deg``, ``effort_Nms``
        (``int |Mz_act| dt``), ``max_abs_Mz``, ``saturated_pct``, ``rms_Mz_cmd``, ``rms_dMz_dt`` and
        ``max_dMz_dt`` [N m/s], ``max_counter_Mz_launch`` (the largest moment against the driver's
        steering while the car accelerates to 95 % of its top speed) - all while ``v > v_min``.
    """
    model = BicycleModel.from_vehicle(vehicle, mu, nominal=True)
    ref = ReferenceModel(model, *REFERENCE_LAGS, Ts, mu)
    vx, delta = a["plant.vx"], a["driver.delta_f"]
    beta_ref, gamma_ref = ref.run(delta, np.maximum(vx, v_min))
    mask = vx > v_min
    mz_act = np.abs(a["plant.Mz_act"])
    dt = float(a["time"][1] - a["time"][0])
    cmd = np.asarray(a.get("controller.Mz_cmd", np.zeros_like(vx)), dtype=float)
    rate = np.diff(cmd, prepend=cmd[0]) / dt
    limit = Mz_max or yaw_moment_limit(vehicle)
    launch = np.arange(len(vx)) < int(np.argmax(vx >= 0.95 * vx.max()))
    steer = np.abs(delta) > 0.005
    counter = -np.sign(delta) * cmd
    return {"max_abs_beta_deg": float(np.max(np.abs(a["plant.beta"][mask])) * DEG),
            "rms_yaw_rate_error_deg_s": rms((a["plant.yaw_rate"] - gamma_ref)[mask]) * DEG,
            "rms_beta_error_deg": rms((a["plant.beta"] - beta_ref)[mask]) * DEG,
            "effort_Nms": float(mz_act.sum() * dt), "max_abs_Mz": float(mz_act.max()),
            "saturated_pct": 100.0 * float(np.mean(np.abs(cmd[mask]) >= 0.999 * limit)),
            "rms_Mz_cmd": rms(cmd[mask]), "rms_dMz_dt": rms(rate[mask]), "max_dMz_dt": float(np.max(np.abs(rate))),
            "max_counter_Mz_launch": float(max(0.0, np.max(counter[launch & steer], initial=0.0)))}
