"""Rewrite build-container include paths in the ROS wheels' CMake exports.

The PyPI ROS 2 wheels export CMake targets whose INTERFACE_INCLUDE_DIRECTORIES
name ``/opt/python/cp3XX-cp3XX/include/python3.X`` and that container's numpy
include directory. CMake's generate step rejects paths that do not exist, so
the interface packages could not be built against them. This points them at the
running interpreter's include directory and ``numpy.get_include()``.
"""
import pathlib
import re
import sys
import sysconfig

import numpy

venv = pathlib.Path(sys.argv[1])
py_inc = sysconfig.get_paths()["include"]
np_inc = numpy.get_include()
pattern = re.compile(r"/opt/python/cp\d+-cp\d+/(include/python3\.\d+|lib/python3\.\d+/site-packages/numpy/(?:_core|core)/include)")


def repl(match: re.Match) -> str:
    return py_inc if match.group(1).startswith("include") else np_inc


count = 0
for path in (venv / "share").glob("*/cmake/*.cmake"):
    text = path.read_text()
    new = pattern.sub(repl, text)
    if new != text:
        path.write_text(new)
        count += 1
print(f"[setup] rewrote include paths in {count} CMake export files")
