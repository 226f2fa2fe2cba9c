"""Named sensor grades (IMU, GNSS receiver, magnetometer, barometer) with their figures and the source of each.

A scenario selects one per sensor block with ``<block>: {grade: <name>, ...}``
(``imu: {grade: tactical}``, ``gnss: {grade: ublox_m8}``,
``magnetometer: {grade: rm3100}``, ``barometer: {grade: ms5611}``); fields
given beside ``grade`` override the grade's (``apply_grade``). The figures
are the block's own fields in its own units (``imu_model.CONFIG_FIELDS``,
the scenario's ``gnss.*`` fix model, ``mag_model.CONFIG_FIELDS``,
``baro_model.CONFIG_FIELDS``). IMU ``bias`` figures are 1-sigma magnitudes
(the sign of a unit's turn-on bias is unknown; a grade applied to a
scenario gives +, -, + per axis as the scenarios' hand-written values do).
Every figure names its source; a figure no cited source gives is marked
``assumed`` with the reason, and a conversion (CEP or 95 % to a per-axis
1-sigma, a pressure range to an altitude) says how it was made.

Sources:
  [ES20] N. El-Sheimy, A. Youssef, "Inertial sensors technologies for
         navigation applications: state of the art and future trends",
         Satellite Navigation 1:2 (2020), Table 1 (IMU classes).
  [FSAS] iMAR iIMU-FSAS figures as tabulated in Math. Probl. Eng. 2013,
         435286, Table 6 ("Specifications of tested IMUs").
  [MTIG] Xsens MTi-G figures, same table as [FSAS].
  [MTI1] Xsens MTi-1 data sheet figures as tabulated in Trans. Aerospace
         Research 2023-0022, "Characteristics of IMU Xsens MTi-1 sensors".
  [SPS]  GPS Standard Positioning Service Performance Standard, 5th ed.
         (2020), section 3.8: position accuracy <= 9 m horizontal and
         <= 15 m vertical, 95 %, global average.
  [M8]   u-blox NEO-M8 data sheet: horizontal position accuracy 2.5 m CEP
         (GNSS, autonomous), velocity accuracy 0.05 m/s (50 %).
  [F9P]  u-blox ZED-F9P data sheet: position accuracy (PVT) 1.5 m CEP,
         velocity accuracy 0.05 m/s (50 %).
  [HMC]  Honeywell HMC5883L data sheet: noise floor 2 milli-gauss (standard
         deviation of 100 readings), maximum continuous output rate 75 Hz.
  [RM31] PNI RM3100 data sheet: noise 15 nT at cycle count 200.
  [BMP3] Bosch BMP388 data sheet: operating range 300-1250 hPa, relative
         accuracy +-8 Pa, absolute accuracy +-50 Pa.
  [MS56] TE MS5611-01BA03 data sheet: range 10-1200 mbar, resolution (RMS)
         0.012 mbar at OSR 4096, accuracy +-1.5 mbar at 25 degC.

Conversions (per axis, a circular normal horizontal error): CEP = 1.1774
sigma, horizontal 95 % radius = 2.4477 sigma, one-axis 95 % = 1.96 sigma, a
50 % speed figure taken per axis as 0.6745 sigma; a data sheet that gives no
vertical figure: vertical sigma = 1.7 x horizontal (assumed: a VDOP/HDOP
ratio of open-sky geometries; [SPS]'s own ratio of 95 % figures, 15/9 = 1.67,
is the same). A barometer's highest altitude is where US76 static pressure
(``hyper_nav_filter.core.atmosphere``) falls to the low end of its range.
"""
from __future__ import annotations

import copy

from scipy.optimize import brentq

from hyper_nav_filter.core.atmosphere import pressure_Pa
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

VECTOR_FIELDS = {"gyro_bias_deg_per_hr", "accel_bias_ug"}       # IMU biases: +, -, + per axis

_CEP, _R95, _N95, _MEDIAN1D, _V_OVER_H = 1.1774, 2.4477, 1.96, 0.6745, 1.7


def _enu(h_m: float, v_m: float) -> list:
    return [round(h_m, 4), round(h_m, 4), round(v_m, 4)]


def altitude_of_pressure_m(p_pa: float) -> float:
    """US76 geometric altitude [m] where the static pressure is ``p_pa`` (0-86 km)."""
    return float(brentq(lambda h: float(pressure_Pa(h)) - p_pa, -500.0, 86000.0, xtol=1e-3))


# The GNSS receiver's fixes (the scenario's white-noise fix model: gnss.pos_sigma_enu_m, vel_sigma_enu_mps, rate_hz)
GNSS_GRADES: dict[str, dict] = {
    "gps_sps": {
        "description": "GPS L1 C/A single-frequency receiver at the SPS performance standard [SPS]",
        "pos_sigma_enu_m": (_enu(9.0 / _R95, 15.0 / _N95),
                            "[SPS] 9 m horizontal / 15 m vertical 95 % -> 3.68 m per horizontal axis, 7.65 m up"),
        "vel_sigma_enu_mps": (_enu(0.1, 0.1 * _V_OVER_H), "assumed: [SPS] states no velocity accuracy; 0.1 m/s per "
                                                          "horizontal axis, 0.17 m/s up"),
        "rate_hz": (1.0, "assumed: the usual 1 Hz output of a standard receiver"),
    },
    "ublox_m8": {
        "description": "u-blox NEO-M8 (GPS + GLONASS / BeiDou, single frequency) [M8]",
        "pos_sigma_enu_m": (_enu(2.5 / _CEP, 2.5 / _CEP * _V_OVER_H),
                            "[M8] 2.5 m CEP -> 2.12 m per horizontal axis; up 1.7 x (assumed: no vertical figure)"),
        "vel_sigma_enu_mps": (_enu(0.05 / _MEDIAN1D, 0.05 / _MEDIAN1D * _V_OVER_H),
                              "[M8] 0.05 m/s (50 %) -> 0.074 m/s per horizontal axis; up 1.7 x (assumed)"),
        "rate_hz": (5.0, "assumed: 5 Hz, within the module's navigation update rates"),
    },
    "ublox_f9p": {
        "description": "u-blox ZED-F9P multi-band receiver, standalone (no RTK corrections) [F9P]",
        "pos_sigma_enu_m": (_enu(1.5 / _CEP, 1.5 / _CEP * _V_OVER_H),
                            "[F9P] PVT 1.5 m CEP -> 1.27 m per horizontal axis; up 1.7 x (assumed: no vertical "
                            "figure)"),
        "vel_sigma_enu_mps": (_enu(0.05 / _MEDIAN1D, 0.05 / _MEDIAN1D * _V_OVER_H),
                              "[F9P] 0.05 m/s (50 %) -> 0.074 m/s per horizontal axis; up 1.7 x (assumed)"),
        "rate_hz": (10.0, "assumed: 10 Hz, within the module's navigation update rates"),
    },
}

# The magnetometer (mag_model: white noise per axis; magnetometer.rate_hz)
MAGNETOMETER_GRADES: dict[str, dict] = {
    "hmc5883l": {
        "description": "Honeywell HMC5883L anisotropic magneto-resistive, consumer [HMC]",
        "noise_nT": (200.0, "[HMC] noise floor 2 milli-gauss (1 mG = 100 nT), a standard deviation"),
        "rate_hz": (75.0, "[HMC] highest continuous-mode output rate"),
    },
    "rm3100": {
        "description": "PNI RM3100 magneto-inductive, navigation-grade small sensor [RM31]",
        "noise_nT": (15.0, "[RM31] 15 nT at cycle count 200"),
        "rate_hz": (50.0, "assumed: 50 Hz, within the sensor's three-axis rates at cycle count 200"),
    },
}

# The barometer (baro_model: pressure noise and bias; barometer.rate_hz; the model's validity max_alt_m)
BAROMETER_GRADES: dict[str, dict] = {
    "bmp388": {
        "description": "Bosch BMP388 MEMS barometer (300-1250 hPa) [BMP3]",
        "pressure_noise_pa": (8.0, "[BMP3] relative accuracy +-8 Pa, taken as the 1-sigma noise (assumed)"),
        "pressure_bias_pa": (50.0, "[BMP3] absolute accuracy +-50 Pa, taken as the 1-sigma bias (assumed)"),
        "max_alt_m": (round(altitude_of_pressure_m(30000.0)), "[BMP3] range down to 300 hPa: US76 altitude of "
                                                               "30 kPa"),
        "rate_hz": (25.0, "assumed: 25 Hz, within the sensor's output data rates"),
    },
    "ms5611": {
        "description": "TE MS5611 MEMS barometer (10-1200 mbar) [MS56]",
        "pressure_noise_pa": (1.2, "[MS56] resolution 0.012 mbar RMS at OSR 4096"),
        "pressure_bias_pa": (150.0, "[MS56] accuracy +-1.5 mbar at 25 degC, taken as the 1-sigma bias (assumed)"),
        "max_alt_m": (round(altitude_of_pressure_m(1000.0)), "[MS56] range down to 10 mbar: US76 altitude of 1 kPa"),
        "rate_hz": (25.0, "assumed: 25 Hz, within the conversion rates at OSR 4096"),
    },
}

# scenario block -> its grades
CATALOGUE: dict[str, dict] = {"imu": IMU_GRADES, "gnss": GNSS_GRADES, "magnetometer": MAGNETOMETER_GRADES,
                              "barometer": BAROMETER_GRADES}


def grade_figures(name: str, block: str = "imu") -> dict:
    """{field: value} of a grade of ``block``'s sensor (its own units); did-you-mean on an unknown name."""
    grades = CATALOGUE[block]
    if name not in grades:
        best = suggestion(name, sorted(grades))
        hint = f"; did you mean '{best}'?" if best else f" (known: {', '.join(sorted(grades))})"
        raise ValueError(f"{block}.grade: unknown grade {name!r}{hint}")
    return {k: copy.deepcopy(v[0]) for k, v in grades[name].items() if k != "description"}


def apply_grade(block: dict, name: str = "imu") -> dict:
    """The ``name`` block (imu, gnss, magnetometer, barometer) with its
    ``grade`` expanded: the grade's figures (IMU bias vectors +, -, + per
    axis), then the block's own fields over them."""
    if not isinstance(block, dict) or "grade" not in block:
        return block
    out = {}
    for k, v in grade_figures(str(block["grade"]), name).items():
        out[k] = [s * v for s in _SIGNS] if name == "imu" and k in VECTOR_FIELDS else v
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
