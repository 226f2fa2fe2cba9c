"""The simulated GNSS world (GPS + BeiDou): what the signals really go through and what a receiver on the
simulated vehicle outputs.

* :mod:`.world` orbit/clock errors, ionosphere and troposphere as they are (not the broadcast models;
  STYLE pattern 16), sized by :mod:`.broadcast_error` from real data;
* :mod:`.observables` pseudoranges and Doppler of a moving receiver (seed 004 eq. 10);
* :mod:`.signal_env` C/N0 of a body-mounted antenna, plasma sheath; :mod:`.receiver_tracking` the receiver-level
  tracking option (the loops themselves are the GNSS library's, :mod:`hyper_nav_gnss.receiver.tracking`);
* :mod:`.receiver` the receiver simulator (raw epochs, lock state, PVT fix); :mod:`.undetected_lock_loss`.

The receiver-side models (broadcast ephemeris, light time, Klobuchar, Hopfield, PVT, lock) are the GNSS library's
(:mod:`hyper_nav_gnss`); import them from there.
"""
