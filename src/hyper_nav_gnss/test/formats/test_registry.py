"""The receiver-format registry: one place chooses the reader of a user's receiver file (issue 34)."""
import gzip

import pytest

from hyper_nav_gnss.formats import registry
from hyper_nav_gnss.formats.registry import RECEIVER_FORMATS, ReceiverFormat, ReceiverLog, detect, receiver_format

RINEX3_OBS_HEAD = ("     3.04           OBSERVATION DATA    M                   RINEX VERSION / TYPE\n"
                   "                                                            END OF HEADER\n")


def test_every_format_is_registered_once_with_its_reader():
    assert set(RECEIVER_FORMATS) == {"ubx", "rinex"}
    for name, fmt in RECEIVER_FORMATS.items():
        assert fmt.name == name and callable(fmt.read) and callable(fmt.sniff)
    assert receiver_format("rinex").needs_nav and not receiver_format("ubx").needs_nav
    with pytest.raises(KeyError):
        receiver_format("rtcm3")


def test_detect_tells_the_format_from_the_first_bytes_and_the_archive_names(tmp_path):
    (tmp_path / "rover.bin").write_bytes(b"\xb5\x62\x02\x15" + bytes(20))
    (tmp_path / "station.obs").write_text(RINEX3_OBS_HEAD)
    (tmp_path / "nav.rnx").write_text(RINEX3_OBS_HEAD.replace("OBSERVATION DATA    M", "N: GNSS NAV DATA     M"))
    with gzip.open(tmp_path / "TLSE00FRA_R_20240011200_15M_01S_MO.crx.gz", "wb") as f:
        f.write(b"compressed")
    (tmp_path / "notes.txt").write_text("hello")
    assert detect(tmp_path / "rover.bin") == "ubx"
    assert detect(tmp_path / "station.obs") == "rinex"
    assert detect(tmp_path / "TLSE00FRA_R_20240011200_15M_01S_MO.crx.gz") == "rinex"
    assert detect(tmp_path / "nav.rnx") is None          # a navigation file is not a receiver file
    assert detect(tmp_path / "notes.txt") is None


def test_a_new_format_is_one_entry(tmp_path, monkeypatch):
    """A reader and its entry: the commands' lookups (detect, receiver_format) find it with nothing else changed."""
    def read_csv(path, signals=None, max_epochs=None, observables="CLDS"):
        return ReceiverLog(epochs=[path.read_text()])
    fmt = ReceiverFormat("mycsv", "a test format", read_csv, needs_nav=True, sniff=lambda head: head[:6] == b"MYCSV,")
    monkeypatch.setitem(registry.RECEIVER_FORMATS, "mycsv", fmt)
    (tmp_path / "log.csv").write_text("MYCSV,1")
    assert detect(tmp_path / "log.csv") == "mycsv"
    assert receiver_format("mycsv").read(tmp_path / "log.csv").epochs == ["MYCSV,1"]
