"""Named IMU grades with their figures and the source of each figure.

A scenario selects one with ``imu: {grade: tactical, ...}``; fields given
beside ``grade`` override the grade's (``apply_grade``). The figures are
the ``imu`` block's own fields (datasheet units, ``imu_model.CONFIG_FIELDS``);
``bias`` figures are 1-sigma magnitudes (the sign of a unit's turn-on bias
is unknown; a grade applied to a scenario gives +, -, + per axis as the
scenarios' hand-written values do). Every figure names its source; a figure
no cited source gives is marked ``assumed`` with the reason.

Sources:
  [ES20] N. El-Sheimy, A. Youssef, "Inertial sensors technologies for
         navigation applications: state of the art and future trends",
         Satellite Navigation 1:2 (2020), Table 1 (IMU classes).
  [FSAS] iMAR iIMU-FSAS figures as tabulated in Math. Probl. Eng. 2013,
         435286, Table 6 ("Specifications of tested IMUs").
  [MTIG] Xsens MTi-G figures, same table as [FSAS].
  [MTI1] Xsens MTi-1 data sheet figures as tabulated in Trans. Aerospace
         Research 2023-0022, "Characteristics of IMU Xsens MTi-1 sensors".
"""
from __future__ import annotations

import copy

from hyper_nav_filter.core.params import suggestion

_SIGNS = (1.0, -1.0, 1.0)

# grade -> {field: (value, source)}
IMU_GRADES: dict[str, dict] = {
    "navigation": {
        "description": "navigation grade (ring-laser / fibre-optic gyros), the class of [ES20]",
        "gyro_bias_deg_per_hr": (0.01, "[ES20] navigation grade: gyro drift < 0.01 deg/h"),
        "gyro_arw_deg_per_sqrt_hr": (0.002, "[ES20] gyro random walk, the table's bound for the best classes "
                                            "(< 0.002 deg/sqrt(h))"),
        "accel_bias_ug": (100.0, "[ES20] navigation grade: accelerometer bias < 100 ug"),
        "accel_vrw_ug_per_sqrt_hz": (10.0, "assumed: [ES20] gives no accelerometer noise; 10 ug/sqrt(Hz) is a "
                                           "tenth of the tactical unit below"),
    },
    "tactical": {
        "description": "tactical grade FOG IMU, iMAR iIMU-FSAS [FSAS]",
        "gyro_bias_deg_per_hr": (0.75, "[FSAS] gyro bias 0.75 deg/h"),
        "gyro_arw_deg_per_sqrt_hr": (0.1, "[FSAS] gyro noise 0.1 deg/sqrt(h)"),
        "accel_bias_ug": (1000.0, "[FSAS] accelerometer bias 1000 ug"),
        "accel_vrw_ug_per_sqrt_hz": (0.03 * 60.0 / 9.80665 * 1e6 / 3600.0,
                                     "[FSAS] accelerometer noise 0.03 m/s/sqrt(h) (= 51 ug/sqrt(Hz))"),
    },
    "industrial_mems": {
        "description": "industrial MEMS module, Xsens MTi-1 [MTI1]",
        "gyro_bias_deg_per_hr": (10.0, "[MTI1] gyro zero-offset (in-run) instability 10 deg/h, taken as the "
                                       "turn-on 1-sigma (assumed: no turn-on figure in the source)"),
        "gyro_arw_deg_per_sqrt_hr": (0.007 * 60.0, "[MTI1] gyro noise density 0.007 deg/s/sqrt(Hz) "
                                                   "(= 0.42 deg/sqrt(h))"),
        "accel_bias_ug": (30.0, "[MTI1] accelerometer zero-offset instability 0.03 mg, taken as the turn-on "
                                "1-sigma (assumed: no turn-on figure in the source)"),
        "accel_vrw_ug_per_sqrt_hz": (120.0, "[MTI1] accelerometer noise density 120 ug/sqrt(Hz)"),
    },
    "automotive": {
        "description": "automotive / consumer MEMS, Xsens MTi-G [MTIG]",
        "gyro_bias_deg_per_hr": (3600.0, "[MTIG] gyro bias 3600 deg/h"),
        "gyro_arw_deg_per_sqrt_hr": (3.0, "[MTIG] gyro noise 3 deg/sqrt(h)"),
        "accel_bias_ug": (2000.0, "[MTIG] accelerometer bias 2000 ug"),
        "accel_vrw_ug_per_sqrt_hz": (0.12 * 60.0 / 9.80665 * 1e6 / 3600.0,
                                     "[MTIG] accelerometer noise 0.12 m/s/sqrt(h) (= 204 ug/sqrt(Hz))"),
    },
}

VECTOR_FIELDS = {"gyro_bias_deg_per_hr", "accel_bias_ug"}


def grade_figures(name: str) -> dict:
    """{field: value} of a grade (datasheet units); did-you-mean on an unknown name."""
    if name not in IMU_GRADES:
        best = suggestion(name, sorted(IMU_GRADES))
        hint = f"; did you mean '{best}'?" if best else f" (known: {', '.join(sorted(IMU_GRADES))})"
        raise ValueError(f"imu.grade: unknown grade {name!r}{hint}")
    return {k: v[0] for k, v in IMU_GRADES[name].items() if k != "description"}


def apply_grade(block: dict) -> dict:
    """The ``imu`` block with its ``grade`` expanded: the grade's figures
    (bias vectors +, -, + per axis), then the block's own fields over them."""
    if not isinstance(block, dict) or "grade" not in block:
        return block
    out = {}
    for k, v in grade_figures(str(block["grade"])).items():
        out[k] = [s * v for s in _SIGNS] if k in VECTOR_FIELDS else v
    for k, v in block.items():
        if k != "grade":
            out[k] = copy.deepcopy(v)
    return out


def filter_tuning(name: str) -> dict:
    """``filter.config`` fields matching a grade (what a team tunes its filter
    to when it fits that IMU): assumed noise = the grade's, bias 1-sigma = the
    grade's turn-on bias, random constants over the flight."""
    f = grade_figures(name)
    return {"gyro_arw_deg_per_sqrt_hr": f["gyro_arw_deg_per_sqrt_hr"],
            "accel_vrw_ug_per_sqrt_hz": f["accel_vrw_ug_per_sqrt_hz"],
            "gyro_bias_sigma_deg_per_hr": f["gyro_bias_deg_per_hr"], "gyro_bias_tau_s": 36000.0,
            "accel_bias_sigma_ug": f["accel_bias_ug"], "accel_bias_tau_s": 36000.0}
