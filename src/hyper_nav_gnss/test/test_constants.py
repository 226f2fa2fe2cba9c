"""The speed of light has one home (issue 34): core/gnss/constants.py, imported by every package."""
import pathlib
import re

from hyper_nav_gnss.constants import C_MPS

SRC = pathlib.Path(__file__).resolve().parents[2]          # src/


def test_speed_of_light_is_the_interface_documents_value():
    assert C_MPS == 299792458.0


def test_speed_of_light_defined_once_in_the_sources():
    """No module but constants.py writes the value or assigns C_MPS (tests are free to)."""
    places = []
    for path in SRC.glob("*/*/**/*.py"):
        if "/test/" in str(path) or path.name == "constants.py":
            continue
        text = path.read_text()
        if "299792458" in text or re.search(r"^\s*C_MPS\s*=", text, re.M):
            places.append(str(path.relative_to(SRC)))
    assert places == [], places
