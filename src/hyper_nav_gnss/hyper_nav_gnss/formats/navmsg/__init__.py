"""Broadcast navigation messages decoded from their subframe / page bits into
:class:`~hyper_nav_gnss.orbits.ephemeris.BroadcastEphemeris` records and
ionosphere coefficients, one module per message:

* :mod:`.gps_lnav`  GPS (and QZSS) LNAV subframes 1-3 and subframe 4 page 18 (IS-GPS-200 20.3.3);
* :mod:`.bds_d1`    BeiDou D1 subframes 1-3 (BDS-SIS-ICD-B1I 3.0, 5.2.4; MEO/IGSO satellites);
* :mod:`.gal_inav`  Galileo I/NAV word types 1-5 (Galileo OS SIS ICD 2.0, 4.3.5);
* :mod:`.bits`      bit fields, the URA/SISA tables and CRC-24Q.

Hand-decoded: among this project's dependencies only RTKLIB (through
pyrtklib) decodes these bits, and its decoders take C byte buffers the
binding does not expose (``decode_frame(uint8_t *...)``); its whole-stream
UBX reader (``input_ubxf``) does run and is what the tests compare these
decoders with (an independent implementation). Each assembler keeps the
latest words per satellite, emits a record once a consistent set (same issue
of data) is complete, and counts what it skipped.
"""
