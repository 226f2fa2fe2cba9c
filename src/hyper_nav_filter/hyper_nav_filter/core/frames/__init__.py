"""Mechanization frames of the filter's nominal state, selected by
``FilterConfig.mechanization_frame``. A frame owns: its nominal vector, the
strapdown mechanization, the 9 x 9 att/vel/pos error dynamics and the
body-to-frame rotation through which every sensor-error block couples, the
injection of att/vel/pos corrections, the geodetic/ENU view of its state and
the transform of its att/vel/pos errors into the ENU convention that
measurement models and outputs use."""
from __future__ import annotations

from .enu import EnuFrame
from .lci import LciFrame

FRAMES = {"ENU": EnuFrame, "LCI": LciFrame}


def make_frame(cfg, initial, **kw):
    return FRAMES[cfg.mechanization_frame](cfg, initial, **kw)
