#!/usr/bin/env python3
"""Is the installed torch the one requirements.txt pins? Used by scripts/setup.sh.

Accepted: the pinned version with no local label or with +cpu or +cuXYZ (PyPI serves a CUDA build
as plain "2.13.0" on x86_64 Linux, download.pytorch.org serves "2.13.0+cpu" / "2.13.0+cu126").
Anything else (another version, a nightly, a ROCm build) is refused.

    python scripts/check_torch.py                 # the torch installed in this interpreter
    python scripts/check_torch.py 2.13.0+cu126    # a version string (tests)
    python scripts/check_torch.py --print-pin     # the pin read from requirements.txt

Exit 0 when accepted (one line on stdout), 1 when refused (one line on stderr). Standard library
only: setup.sh may run it before anything is installed.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

REQUIREMENTS = Path(__file__).resolve().parent.parent / "requirements.txt"
CPU_INDEX_URL = "https://download.pytorch.org/whl/cpu"
_LOCAL_OK = re.compile(r"cpu|cu\d+")


def pin_from_requirements(path: Path = REQUIREMENTS) -> str:
    """The X of the `torch==X` line in requirements.txt."""
    for line in path.read_text().splitlines():
        m = re.match(r"\s*torch\s*==\s*([^\s;#]+)", line)
        if m:
            return m.group(1)
    raise SystemExit(f"setup: no torch==... line in {path}")


def check(version: str, pin: str, cuda: str | None = None) -> tuple[bool, str]:
    """(accepted, message) for torch `version` against the pinned `pin`.

    `cuda` is torch.version.cuda when known (a plain "2.13.0" from PyPI is a CUDA build too).
    """
    public, _, local = version.strip().partition("+")
    if public != pin or (local and not _LOCAL_OK.fullmatch(local)):
        return False, (f"setup: torch {version} installed, but requirements.txt pins torch=={pin} "
                       f"(accepted: {pin}, {pin}+cpu, {pin}+cuXYZ)")
    if local.startswith("cu") or cuda:
        build = f"CUDA {cuda} build" if cuda else "CUDA build"
        return True, (f"setup: torch {version} (the pinned {pin}, {build}; runs on the CPU too). "
                      f"CPU-only wheel, no nvidia-* packages: rm -rf .venv && "
                      f"TORCH_INDEX_URL={CPU_INDEX_URL} make setup")
    return True, f"setup: torch {version} (the pinned {pin})"


def installed() -> tuple[str, str | None]:
    """Version and CUDA version of the torch in this interpreter, without importing torch."""
    import importlib.metadata as md

    try:
        dist = md.distribution("torch")
    except md.PackageNotFoundError:
        raise SystemExit("setup: torch is not installed in this environment") from None
    cuda = None
    version_py = Path(str(dist.locate_file("torch/version.py")))
    if version_py.is_file():
        m = re.search(r"^cuda\s*(?::[^=\n]*)?=\s*['\"]([^'\"]+)['\"]", version_py.read_text(), re.M)
        cuda = m.group(1) if m else None
    return dist.version, cuda


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("version", nargs="?", help="torch version string (default: the installed torch)")
    ap.add_argument("--pin", help="pinned version (default: from requirements.txt)")
    ap.add_argument("--cuda", help="torch.version.cuda of that build, if known")
    ap.add_argument("--print-pin", action="store_true", help="print the pin and exit")
    args = ap.parse_args(argv)
    pin = args.pin or pin_from_requirements()
    if args.print_pin:
        print(pin)
        return 0
    version, cuda = (args.version, args.cuda) if args.version else installed()
    ok, message = check(version, pin, cuda)
    print(message, file=sys.stdout if ok else sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
