"""The walk_0827 recording (u-blox + MEMS IMU) reproduced: TC / LC / SPP against RTK, outages."""
