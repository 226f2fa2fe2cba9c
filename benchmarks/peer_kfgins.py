"""The C++ peer, KF-GINS (i2Nav-WHU, GPL-3.0), built from its source at
benchmark time and run on the same files as the project's user path.

The source is an archive outside the repository (``../shared/peers``, or the
folder ``HYPER_NAV_PEERS`` names; its README gives provenance, licence and the
build). Nothing of it is copied into the repository: the archive is unpacked
and built (CMake, Release, ``make -j2``) into a folder under the system's
temporary directory named after the archive's SHA-256, so the build (about
1.5 min on 2 cores) is paid once per machine and archive; ``rebuild=True``
(``--rebuild-peer``) builds afresh. On a machine without the archive (or
without cmake / a C++ compiler) ``find_archive``/``build`` return None with
the reason, and the benchmarks skip the peer and say so.

    python benchmarks/peer_kfgins.py [--rebuild]      # build (or find) it; print the binary's path
"""
from __future__ import annotations

import hashlib
import os
import pathlib
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
BINARY = pathlib.Path("KF-GINS") / "bin" / "KF-GINS"


def peers_dirs() -> list[pathlib.Path]:
    """Where the peers' archives are looked for, first hit wins."""
    env = os.environ.get("HYPER_NAV_PEERS")
    dirs = [pathlib.Path(env)] if env else []
    return dirs + [HERE.parent.parent / "shared" / "peers", pathlib.Path("/work/shared/peers")]


def find_archive() -> tuple[pathlib.Path | None, str]:
    """(the KF-GINS source archive, "") or (None, why not)."""
    for d in peers_dirs():
        hits = sorted(d.glob("KF-GINS*.tar.gz")) if d.is_dir() else []
        if hits:
            return hits[-1], ""
    return None, "no KF-GINS*.tar.gz in " + ", ".join(map(str, peers_dirs()))


def _sha(path: pathlib.Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:16]


def build(rebuild: bool = False, log=print) -> tuple[pathlib.Path | None, dict]:
    """(path of the built KF-GINS binary, info) or (None, {"skipped": reason}).
    info: archive, build folder, build_s (0 when an earlier build was reused)."""
    archive, why = find_archive()
    if archive is None:
        return None, {"skipped": why}
    for tool in ("cmake", "make", "c++"):
        if shutil.which(tool) is None:
            return None, {"skipped": f"{tool} not on PATH", "archive": str(archive)}
    root = pathlib.Path(tempfile.gettempdir()) / f"hyper_nav_kfgins_{_sha(archive)}"
    exe = root / BINARY
    info = {"archive": str(archive), "build_dir": str(root), "build_s": 0.0, "reused": True}
    if exe.exists() and not rebuild:
        return exe, info
    if root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True)
    t0 = time.monotonic()
    log(f"[peer] building KF-GINS from {archive} in {root} (CMake Release, make -j2; about 1.5 min on 2 cores)")
    with tarfile.open(archive) as tf:
        tf.extractall(root, filter="data")
    src = root / "KF-GINS"
    for cmd in (["cmake", "-S", str(src), "-B", str(src / "build"), "-DCMAKE_BUILD_TYPE=Release"],
                ["make", "-C", str(src / "build"), "-j2"]):
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if p.returncode != 0:
            return None, {**info, "skipped": f"build failed ({' '.join(cmd[:2])}): {p.stdout[-1500:]}"}
    if not exe.exists():
        return None, {**info, "skipped": f"build made no {exe}"}
    info.update(build_s=time.monotonic() - t0, reused=False)
    return exe, info


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rebuild", action="store_true")
    a = ap.parse_args(argv)
    exe, info = build(a.rebuild)
    print(exe if exe else f"peer skipped: {info['skipped']}", info)
    return 0 if exe else 1


if __name__ == "__main__":
    sys.exit(main())
