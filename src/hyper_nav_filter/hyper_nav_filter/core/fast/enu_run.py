"""A run of in-order IMU samples through the ENU predict in one compiled
call (``core.fusion_run``): per sample, the checks of
``FusionEngine.add_imu_rates`` (finite, after the latest epoch, no gap), the
increments rate * dt, and ``enu.predict`` itself, the same compiled function
the per-sample path calls, so each epoch's nominal state and covariance are
the per-sample path's bit for bit (tested: ``test_fusion_run``)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .enu import predict

EPS_S = 1e-9                # fusion._EPS_S

# why a run stopped (the sample at the returned count is left to the per-sample path)
STOP_END, STOP_EVENT, STOP_INVALID, STOP_GAP = 0, 1, 2, 3


def columns(nx: int) -> dict:
    """Column slices of a run's epoch rows (``predict_run``'s E) for a nominal vector of nx."""
    return {"x": slice(0, nx), "dth": slice(nx, nx + 3), "dv": slice(nx + 3, nx + 6), "t": nx + 6, "dt": nx + 7}


@njit(cache=True)
def predict_run(x0, vals, P0, t0, pdth, pdv, pdt, has_prev, stamps, rates, forces, rows, t_event, gap_s,
                gb, ab, sg, sa, A, Katt, Kvel, used_att, used_vel, Gc, GattM, GvelM, qc, exact, E, PS):
    """Samples ``rows`` of (stamps, rates, forces) (mean body rate and specific
    force over the interval ending at the stamp, as ``add_imu_rates`` takes
    them) from the filter state (x0, vals, P0) at t0, whose previous interval
    is (pdth, pdv, pdt) when ``has_prev``. Sample j is taken while its stamp is
    finite and after the latest epoch, its rates finite, its interval at most
    ``gap_s`` and an event at ``t_event`` does not fall in it (stamp + EPS_S <
    t_event); its epoch goes to row j of E (``columns``: nominal vector,
    increments rate * dt, stamp, interval) and PS[j] (P). Returns (samples
    taken, why the run stopped, Phi of the last step)."""
    n = PS.shape[1]
    nx = x0.shape[0]
    x = x0
    P = P0
    t_prev = t0
    Phi = np.eye(n)
    out = np.empty(x0.shape[0])
    for j in range(rows.shape[0]):
        r = rows[j]
        t = stamps[r]
        ok = math.isfinite(t)
        for a in range(3):
            ok = ok and math.isfinite(rates[r, a]) and math.isfinite(forces[r, a])
        if not ok:
            return j, STOP_INVALID, Phi
        dt = t - t_prev
        if not dt > 0.0:
            return j, STOP_INVALID, Phi
        if dt > gap_s:
            return j, STOP_GAP, Phi
        if not t + EPS_S < t_event:
            return j, STOP_EVENT, Phi
        dth = np.empty(3)
        dv = np.empty(3)
        for a in range(3):
            dth[a] = rates[r, a] * dt
            dv[a] = forces[r, a] * dt
        P, Phi = predict(x, vals, P, dth, dv, dt, pdth, pdv, pdt, has_prev, gb, ab, sg, sa, A, Katt, Kvel,
                         used_att, used_vel, Gc, GattM, GvelM, qc, exact, out)
        row = E[j]
        row[:nx] = out
        row[nx:nx + 3] = dth
        row[nx + 3:nx + 6] = dv
        row[nx + 6] = t
        row[nx + 7] = dt
        PS[j] = P
        x = row[:nx]
        pdth, pdv, pdt, has_prev = row[nx:nx + 3], row[nx + 3:nx + 6], dt, True
        t_prev = t
    return rows.shape[0], STOP_END, Phi
