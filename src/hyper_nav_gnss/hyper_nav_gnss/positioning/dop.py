"""Dilution of precision: the one DOP of the project (single-point positioning and the simulated receiver's PVT).

Of unit line-of-sight rows and clock columns (``H_geo``, ECEF, geometry only: no weights),
Q = (H^T H)^-1; GDOP = sqrt(tr Q), PDOP = sqrt(tr Q_pos), TDOP = sqrt(Q_clk) (the first clock column),
HDOP and VDOP from the position block rotated to ENU at (lat, lon). Keys as RTKLIB writes them: gdop, pdop, hdop,
vdop, tdop; an empty dict when the geometry is singular.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth


def dops(H_geo: np.ndarray, lat_rad: float, lon_rad: float) -> dict:
    """GDOP, PDOP, HDOP, VDOP, TDOP of ``H_geo`` (rows [-u_e, 1, isb columns...]) at (lat, lon)."""
    try:
        Q = np.linalg.inv(H_geo.T @ H_geo)
    except np.linalg.LinAlgError:
        return {}
    C = earth.C_n_e(lat_rad, lon_rad)                       # ENU -> ECEF
    Qp = C.T @ Q[:3, :3] @ C
    return {"gdop": float(np.sqrt(np.trace(Q))), "pdop": float(np.sqrt(np.trace(Q[:3, :3]))),
            "hdop": float(np.sqrt(Qp[0, 0] + Qp[1, 1])), "vdop": float(np.sqrt(Qp[2, 2])),
            "tdop": float(np.sqrt(Q[3, 3]))}
