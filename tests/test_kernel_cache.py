"""Numba's kernel cache is dropped when any file compiled code is built from changes
(components.kernel_cache), and the list of those files is complete."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from components import kernel_cache

PACKAGE = kernel_cache.PACKAGE
PYTHON_ONLY = {"components.messages"}  # imported by a kernel file for type annotations, not compiled in


def _imports(path: Path) -> set[str]:
    """The modules ``path`` imports (``import a.b``, ``from a.b import c``)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found |= {f"{node.module}.{alias.name}" for alias in node.names}  # a submodule, if one
    return found


def _is_module_file(module: str) -> bool:
    """Whether a ``components.*`` name is a module file of the package (not a package or a name)."""
    return (PACKAGE.parent / (module.replace(".", "/") + ".py")).is_file()


def _module(rel: str) -> str:
    return "components." + rel.removesuffix(".py").replace("/", ".")


def test_every_file_compiled_code_is_built_from_is_fingerprinted():
    """Each module of the package that uses numba is listed, and so is every module of the package it
    imports (its kernels and constants are compiled into the importer's code)."""
    listed = {_module(name) for name in kernel_cache.KERNEL_SOURCES}
    for path in sorted(PACKAGE.rglob("*.py")):
        imports = _imports(path)
        if not any(m == "numba" or m.startswith("numba.") for m in imports):
            continue
        rel = path.relative_to(PACKAGE).as_posix()
        assert _module(rel) in listed, f"{rel} uses numba but is not in KERNEL_SOURCES"
        for module in imports:
            if module.startswith("components.") and _is_module_file(module) and module not in PYTHON_ONLY:
                assert module in listed, f"{rel} imports {module}, which is not in KERNEL_SOURCES"


@pytest.fixture
def package(tmp_path, monkeypatch):
    """A stand-in package: two kernel sources, numba cache files beside them, an unrelated file."""
    (tmp_path / "water" / "__pycache__").mkdir(parents=True)
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "water" / "b.py").write_text("y = 2\n")
    monkeypatch.setattr(kernel_cache, "PACKAGE", tmp_path)
    monkeypatch.setattr(kernel_cache, "KERNEL_SOURCES", ("a.py", "water/b.py"))
    monkeypatch.setattr(kernel_cache, "STAMP", tmp_path / "__pycache__" / "kernel-sources.stamp")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    return tmp_path


def _write_caches(root: Path) -> list[Path]:
    (root / "__pycache__").mkdir(exist_ok=True)
    files = [root / "__pycache__" / "a.f-3.py311.nbi", root / "__pycache__" / "a.f-3.py311.1.nbc",
             root / "water" / "__pycache__" / "b.g-9.py311.nbi"]
    for f in files:
        f.write_bytes(b"cached")
    return files


def test_the_cache_is_kept_while_the_sources_are_unchanged_and_dropped_when_one_changes(package):
    caches = _write_caches(package)
    bytecode = package / "__pycache__" / "a.cpython-311.pyc"
    bytecode.write_bytes(b"pyc")
    assert kernel_cache.refresh()  # no fingerprint yet: whatever is cached may be stale
    assert not any(f.exists() for f in caches) and bytecode.exists()
    caches = _write_caches(package)
    assert not kernel_cache.refresh()  # unchanged: kept
    assert all(f.exists() for f in caches)
    (package / "water" / "b.py").write_text("y = 3\n")  # a kernel's source (or a constant) changes
    assert kernel_cache.refresh()
    assert not any(f.exists() for f in caches) and bytecode.exists()
    assert not kernel_cache.refresh()


def test_the_cache_under_numba_cache_dir_is_dropped_too(package, tmp_path_factory, monkeypatch):
    user = tmp_path_factory.mktemp("numba-cache")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(user))
    mirrored = user / (package / "water").relative_to(package.anchor)
    mirrored.mkdir(parents=True)
    cached = mirrored / "b.g-9.py311.nbi"
    cached.write_bytes(b"cached")
    kernel_cache.refresh()
    assert not cached.exists()


def test_the_real_package_has_its_fingerprint_written():
    """Importing components wrote the fingerprint of the sources as they are now."""
    assert kernel_cache.STAMP.read_text() == kernel_cache.fingerprint()
