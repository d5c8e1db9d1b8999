"""Prepare the wheels that ``benchmarks/device_check.sh`` installs on a bare GPU machine.

The device machine has Python 3.12 with NumPy, SciPy, Matplotlib, xarray, h5py, tqdm and pytest,
but no Mitsuba, no Dr.Jit and no package registry; what travels with the working tree is at
most 64 MiB. So this script, run where PyPI is reachable, writes into ``.whl/`` (ignored by
git):

1. ``drjit`` and ``mitsuba`` at the versions installed here, for CPython 3.12 on
   manylinux x86_64 (``pip download``), and the small dependencies the device lacks
   (:data:`SMALL_DEPENDENCIES`);
2. the ``mitsuba`` wheel slimmed to the variants mitsar runs in (``llvm_ad_mono``,
   ``cuda_ad_mono``, plus ``scalar_rgb``): the full wheel (62.6 MB) and Dr.Jit (5 MB) alone
   exceed the limit; the dropped variant libraries, C++ headers and sun-sky data are not
   loaded by mitsar. ``config.py`` lists only the kept variants and ``RECORD`` is rewritten
   (``mitsuba.variants()`` still names all: the list is compiled into the extension);
3. a ``mitsar`` wheel of a commit (``--commit``, default ``HEAD``: pure Python, ``pip wheel
   --no-deps``), so that the device runs committed code, not work in progress around it.

mitsar's other dependencies that the device lacks (h5netcdf, dask, zarr) are imported lazily
and not needed by the GPU tests and benchmarks. Usage:
``.venv/bin/python benchmarks/device_wheels.py [--python-version 3.12] [--out .whl]``.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import importlib.metadata
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

KEEP_VARIANTS = ("scalar_rgb", "llvm_ad_mono", "cuda_ad_mono")
"""Mitsuba variants kept in the slimmed wheel."""

PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64",
             "manylinux2014_x86_64", "manylinux1_x86_64")

SMALL_DEPENDENCIES = ("plyfile", "snaphu")
"""mitsar's dependencies that the device lacks and ``import mitsar`` loads, carried as wheels."""

LIMIT = 64 * 2**20
"""What may travel to the device: working tree plus carried paths [bytes]."""

ROOT = Path(__file__).resolve().parents[1]


def _dropped(name: str) -> bool:
    """Whether a member of the mitsuba wheel is left out of the slimmed one."""
    variant = re.match(r"mitsuba/((?:scalar|llvm|cuda)_\w+?)\.cpython-", name)
    if variant:
        return variant.group(1) not in KEEP_VARIANTS
    return name.startswith(("mitsuba/include/", "mitsuba/data/sunsky/"))


def _record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def slim_mitsuba(wheel: Path) -> Path:
    """Rewrite the mitsuba wheel in place without the unused variants; returns its path."""
    slim = wheel.with_suffix(".slim")
    with zipfile.ZipFile(wheel) as source, zipfile.ZipFile(slim, "w",
                                                           zipfile.ZIP_DEFLATED) as target:
        record_name = next(n for n in source.namelist() if n.endswith(".dist-info/RECORD"))
        lines = []
        for info in source.infolist():
            if info.filename == record_name or _dropped(info.filename):
                continue
            data = source.read(info)
            if info.filename == "mitsuba/config.py":
                data = re.sub(rb"MI_VARIANTS = \[.*?\]",
                              repr(list(KEEP_VARIANTS)).encode().join(
                                  [b"MI_VARIANTS = ", b""]), data)
            info.compress_type = zipfile.ZIP_DEFLATED
            target.writestr(info, data, compresslevel=9)
            lines.append(_record_line(info.filename, data))
        target.writestr(record_name, "\n".join([*lines, f"{record_name},,"]) + "\n")
    slim.replace(wheel)
    return wheel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--python-version", default="3.12")
    parser.add_argument("--out", type=Path, default=ROOT / ".whl")
    parser.add_argument("--commit", default="HEAD", help="commit of the mitsar wheel")
    args = parser.parse_args()
    args.out.mkdir(exist_ok=True)
    for old in args.out.glob("*.whl"):
        old.unlink()
    tag = "cp" + args.python_version.replace(".", "")
    # Dr.Jit and Mitsuba, and the small dependencies `import mitsar` needs that the device
    # lacks (plyfile: the point cloud's PLY; snaphu: unwrapping), at the versions here
    pins = [f"{name}=={importlib.metadata.version(name)}"
            for name in ("drjit", "mitsuba", *SMALL_DEPENDENCIES)]
    subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps",
                    "--only-binary=:all:", "--python-version", args.python_version,
                    "--implementation", "cp", *[f"--platform={p}" for p in PLATFORMS],
                    "-d", str(args.out), *pins], check=True)
    slim_mitsuba(next(args.out.glob(f"mitsuba-*-{tag}-*.whl")))
    with tempfile.TemporaryDirectory() as source:  # the committed tree, not work in progress
        archive = subprocess.run(["git", "archive", args.commit], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", source], input=archive, check=True)
        subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w",
                        str(args.out), source], check=True)
    tree = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                          check=True).stdout.split(b"\0")
    tree_bytes = sum((ROOT / p.decode()).stat().st_size for p in tree
                     if p and (ROOT / p.decode()).is_file())
    wheels = sorted(args.out.glob("*.whl"))
    wheel_bytes = sum(w.stat().st_size for w in wheels)
    for wheel in wheels:
        print(f"{wheel.stat().st_size / 2**20:7.1f} MiB  {wheel.name}")
    total = tree_bytes + wheel_bytes
    print(f"tracked tree {tree_bytes / 2**20:.1f} MiB + wheels {wheel_bytes / 2**20:.1f} MiB = "
          f"{total / 2**20:.1f} MiB of the {LIMIT / 2**20:.0f} MiB that may travel")
    if total > LIMIT:
        sys.exit("too large to travel: drop more from the mitsuba wheel")


if __name__ == "__main__":
    main()
