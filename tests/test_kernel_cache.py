"""The compiled-kernel cache is keyed on the source: a changed file never runs stale kernels."""

from __future__ import annotations

import os
import time

import numba
import pytest

from fsci.kernel_cache import KEEP, configure, source_hash


@pytest.fixture
def package(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    return pkg


def test_changing_any_source_file_changes_the_cache_key(package):
    """numba checks only the defining file's time stamp; the key covers every file's content
    (a kernel compiled against another module's kernel must be rebuilt when that module changes)."""
    first = source_hash(package)
    assert source_hash(package) == first
    (package / "sub" / "b.py").write_text("y = 3\n")
    second = source_hash(package)
    assert second != first
    (package / "sub" / "b.py").write_text("y = 2\n")
    assert source_hash(package) == first
    (package / "sub" / "b.py").rename(package / "b.py")  # same content, other place
    assert source_hash(package) not in (first, second)


def test_the_cache_folder_follows_the_source_and_old_ones_are_pruned(package, tmp_path, monkeypatch):
    """``configure`` points NUMBA_CACHE_DIR (and numba, already imported) at the folder of this
    source version, keeps the KEEP most recent other folders, and leaves a user's own setting."""
    root = tmp_path / "cache" / "fsci" / "numba"
    old = []
    for k in range(KEEP + 2):
        d = root / f"old{k}"
        d.mkdir(parents=True)
        t = time.time() - 1000 * (k + 1)
        os.utime(d, (t, t))
        old.append(d)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    try:
        configure(package)
        here = root / source_hash(package)
        assert os.environ["NUMBA_CACHE_DIR"] == str(here) and here.is_dir()
        assert numba.core.config.CACHE_DIR == str(here)
        assert [d.exists() for d in old] == [True] * KEEP + [False] * 2
        monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
        configure(package)
        assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")
    finally:
        monkeypatch.undo()
        numba.core.config.reload_config()  # the rest of the session compiles into its own folder again
