"""Scratch directories of one benchmark process (scenario files, bags, node
logs), under one root removed when the process exits: the benchmarks leave
nothing behind in the system's temp directory."""
from __future__ import annotations

import atexit
import pathlib
import shutil
import tempfile

_ROOT = pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_bench_"))
atexit.register(shutil.rmtree, _ROOT, True)


def scratch_dir(prefix: str) -> pathlib.Path:
    """A new empty directory under this process's scratch root."""
    return pathlib.Path(tempfile.mkdtemp(prefix=prefix, dir=_ROOT))
