"""Small KF-GINS-format data sets written by the tests from a simulated
flight (the simulator's exact truth and sensor streams, converted to FRD
body, NED, degrees, GNSS seconds of week), so the importer's conversions
can be checked against the native run of the same data."""
import numpy as np
import yaml

from hyper_nav_filter.core.attitude import C_b_n_to_euler
from hyper_nav_sim.core import simulate

T0_SOW = 456300.0          # GNSS seconds of week of the first IMU record (any value)
FRD = np.array([1.0, -1.0, -1.0])


def write_kfgins_set(sc, directory):
    """imu.txt (increments, FRD), gnss.txt (13 columns: pos, NED sigma, NED velocity, sigma),
    truth.nav at the IMU epochs; returns the arrays used."""
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    g = simulate.gnss_stream(sc, traj)
    t_imu = np.concatenate([[0.0], imu.t_s])                    # row 0 starts the time line at t = 0
    dth = np.vstack([np.zeros(3), imu.dtheta_b_rad]) * FRD
    dv = np.vstack([np.zeros(3), imu.dvel_b_mps]) * FRD
    np.savetxt(directory / "imu.txt", np.column_stack([t_imu + T0_SOW, dth, dv]), fmt="%.17g")
    ned = (lambda v: np.column_stack([v[:, 1], v[:, 0], -v[:, 2]]))
    sig = np.tile(np.asarray(sc["gnss.pos_sigma_enu_m"], float)[[1, 0, 2]], (len(g.t_s), 1))
    vsig = np.tile(np.asarray(sc["gnss.vel_sigma_enu_mps"], float)[[1, 0, 2]], (len(g.t_s), 1))
    np.savetxt(directory / "gnss.txt", np.column_stack([g.t_s + T0_SOW, np.rad2deg(g.lat_rad), np.rad2deg(g.lon_rad),
                                                         g.alt_m, sig, ned(g.vel_enu_mps), vsig]), fmt="%.17g")
    tr = traj.truth(t_imu)
    rph = np.rad2deg([C_b_n_to_euler(C) for C in tr.C_b_n])
    np.savetxt(directory / "truth.nav", np.column_stack([np.zeros(len(t_imu)), t_imu + T0_SOW, np.rad2deg(tr.lat_rad),
                                                          np.rad2deg(tr.lon_rad), tr.alt_m, ned(tr.vel_enu_mps), rph]),
               fmt="%.17g")
    return imu, g, tr


def filter_block_of(sc):
    """The scenario's own filter configuration and initial state as an import file's filter block."""
    from hyper_nav_filter.core.initial_state import state_values
    init = state_values(sc.filter_initial_state())
    init["t_s"] = T0_SOW
    return {"config": sc.filter_config().as_dict(), "initial_state": init}


def write_import_file(directory, filter_block, **extra):
    doc = {"preset": "kfgins", "imu": {"file": "imu.txt"}, "gnss": {"file": "gnss.txt"},
           "truth": {"file": "truth.nav"}, "filter": filter_block, **extra}
    path = directory / "import.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path
