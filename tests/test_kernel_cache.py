"""Numba's kernel cache is dropped when any file compiled code is built from changes
(components.kernel_cache), and the list of those files is complete."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from components import kernel_cache

PACKAGE = kernel_cache.PACKAGE
PYTHON_ONLY = {"components.messages",  # imported by a kernel file for type annotations, not compiled in
               "components.kernel_cache"}  # imported to key the cache, not compiled in


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
        rel = path.relative_to(PACKAGE).as_posix()
        if rel == "kernel_cache.py" or not any(m == "numba" or m.startswith("numba.") for m in imports):
            continue  # (kernel_cache reaches numba's cache locators, and compiles nothing)
        assert _module(rel) in listed, f"{rel} uses numba but is not in KERNEL_SOURCES"
        for module in imports:
            if module.startswith("components.") and _is_module_file(module) and module not in PYTHON_ONLY:
                assert module in listed, f"{rel} imports {module}, which is not in KERNEL_SOURCES"


def test_every_module_with_cached_kernels_keys_them_on_every_kernel_source():
    """Each module defining a kernel cached on disk calls kernel_cache.install() before the first
    one (numba picks a kernel's cache locator as it is defined)."""
    for name in kernel_cache.KERNEL_SOURCES:
        text = (PACKAGE / name).read_text()
        first = re.search(r"^@\w+\(.*cache=True", text, re.M)
        if first is None:
            continue
        assert "\nkernel_cache.install()" in text, f"{name} defines cached kernels without kernel_cache.install()"
        assert text.index("\nkernel_cache.install()") < first.start(), name


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


_DRIVER = """
import sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from components import kernel_cache
kernel_cache.PACKAGE = Path(sys.argv[1]) / "toy"
kernel_cache.KERNEL_SOURCES = ("dep.py", "k.py")
if sys.argv[2] == "install":
    kernel_cache.install()
from toy.k import value
print(value())
"""


def _run_toy(root: Path, how: str) -> int:
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _DRIVER, str(root), how], capture_output=True, text=True,
                          env={**__import__("os").environ, "NUMBA_CACHE_DIR": ""}, timeout=300, check=True)
    return int(done.stdout.split()[-1])


def _toy(root: Path) -> Path:
    """A package ``toy`` under ``root``: a kernel in k.py returning a constant of dep.py (1)."""
    toy = root / "toy"
    toy.mkdir()
    (toy / "__init__.py").write_text("")
    (toy / "dep.py").write_text("VALUE = 1\n")
    (toy / "k.py").write_text("from numba import njit\n\nfrom toy.dep import VALUE\n\n\n"
                              "@njit(cache=True)\ndef value():\n    return VALUE\n")
    return toy


@pytest.mark.parametrize("how", ["plain", "install"])
def test_a_kernel_cached_from_other_sources_than_those_on_disk_is_compiled_again(tmp_path, how):
    """A process that read the sources before they changed writes what it compiles from the old text
    (a sweep left running across a git pull, a test run beside an edit), after another process has
    dropped the cache: numba keys a kernel's cache on its own file alone, so a kernel whose file did
    not change, built on a constant of one that did, was loaded stale by every later run (a coupler
    edited in kernel.py ran the old code through step_kernel.ring_step). Keyed on every kernel
    source (kernel_cache.install), it is compiled again: the toy kernel returns its dependency's new
    value, where numba's own key alone ("plain") still gives the old one."""
    toy = _toy(tmp_path)
    assert _run_toy(tmp_path, how) == 1  # compiled and cached
    (toy / "dep.py").write_text("VALUE = 2\n")  # k.py unchanged: numba's own key still matches
    assert _run_toy(tmp_path, how) == (1 if how == "plain" else 2)
    if how == "install":
        assert _run_toy(tmp_path, how) == 2  # and kept, now that it is the one on disk
