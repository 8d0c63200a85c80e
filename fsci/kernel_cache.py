"""Where numba keeps the compiled kernels: one folder per version of fsci's source.

numba's own cache (``cache=True``) is checked against the modification time of the file that
defines a function only. A kernel that calls a kernel of another module (the coupling term's
shape derivative calls the fluid's cell integrand, say) keeps the callee it was compiled with
after that module changed, and silently computes with the old code. Keying the cache folder
on a hash of every source file of the package makes a changed file start a fresh cache.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

KEEP = 3  # cache folders of other source versions kept (most recently used first)


def source_hash(package: Path) -> str:
    """Hash of the relative paths and contents of every ``.py`` file under ``package``."""
    h = hashlib.sha1()
    for p in sorted(package.rglob("*.py")):
        h.update(p.relative_to(package).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def cache_root() -> Path:
    """``$XDG_CACHE_HOME/fsci/numba`` (default ``~/.cache``), or the temporary folder if the
    home folder is not writable."""
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    root = base / "fsci" / "numba"
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError:
        root = Path(tempfile.gettempdir()) / "fsci-numba"
        root.mkdir(parents=True, exist_ok=True)
    return root


def configure(package: str | Path) -> None:
    """Point ``NUMBA_CACHE_DIR`` at the folder of this source version (unless the user set it)
    and remove the folders of all but the ``KEEP`` most recently used other versions. Runs in
    fsci's ``__init__``; if numba was imported before, its configuration is reloaded."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    root = cache_root()
    here = root / source_hash(Path(package))
    here.mkdir(exist_ok=True)
    os.utime(here)  # most recently used
    others = sorted((d for d in root.iterdir() if d.is_dir() and d != here), key=lambda d: d.stat().st_mtime,
                    reverse=True)
    for old in others[KEEP:]:
        shutil.rmtree(old, ignore_errors=True)
    os.environ["NUMBA_CACHE_DIR"] = str(here)
    if "numba" in sys.modules:
        sys.modules["numba"].core.config.reload_config()
