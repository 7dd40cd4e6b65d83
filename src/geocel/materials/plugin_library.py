"""Finding, compiling and loading a UMAT/VUMAT library (the Python side of :mod:`geocel.materials.plugin`).

A source file (C: ``.c``; Fortran: ``.f``, ``.for``, ``.f90``, ``.F``, ``.F90``) is compiled on first use into
the user's cache (``$GEOCEL_CACHE``, else ``$XDG_CACHE_HOME/geocel``, else ``~/.cache/geocel``), keyed by its
content, the compiler and the flags; a compiled library (``.so``, ``.dylib``, ``.dll``) is loaded as it is.
geocel's stand-ins for the Abaqus utility routines (XIT, STDB_ABQERR, ROTSIG) and its ABA_PARAM.INC and
VABA_PARAM.INC come with it (:file:`abaqus/`): they are compiled once and loaded first, so that a library that
calls them links.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

SOURCE_SUFFIXES = {".c": "c", ".f": "fortran", ".for": "fortran", ".f90": "fortran", ".F": "fortran", ".F90": "fortran"}
LIBRARY_SUFFIXES = {".so", ".dylib", ".dll"}
_HERE = Path(__file__).parent / "abaqus"

#: the compilers tried, in order, after $CC / $FC
_COMPILERS = {"c": ("cc", "gcc", "clang"), "fortran": ("gfortran", "ifx", "ifort", "flang")}
_FLAGS = {"c": ["-O2", "-fPIC", "-shared"], "fortran": ["-O2", "-fPIC", "-shared", "-ffixed-line-length-132"]}

#: loaded libraries by resolved path: kept alive for the process (the kernels hold raw addresses into them)
_LOADED: dict[str, ctypes.CDLL] = {}


class PluginError(ValueError):
    """A UMAT/VUMAT library cannot be found, built or loaded, or its subroutine failed (one line; a user's error, as
    a bad scenario value)."""


def cache_dir() -> Path:
    root = os.environ.get("GEOCEL_CACHE")
    if root:
        return Path(root) / "plugins"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "geocel" / "plugins"


def find_compiler(language: str) -> str:
    """The first compiler for ``language`` ("c" or "fortran") on PATH ($CC or $FC first)."""
    env = os.environ.get("CC" if language == "c" else "FC")
    for name in ((env,) if env else ()) + _COMPILERS[language]:
        path = shutil.which(name)
        if path:
            return path
    tried = ", ".join(((f"${'CC' if language == 'c' else 'FC'}",) if env else ()) + _COMPILERS[language])
    raise PluginError(
        f"no {'C' if language == 'c' else 'Fortran'} compiler found (tried {tried}): install one, set "
        f"${'CC' if language == 'c' else 'FC'}, or give a compiled library (.so)"
    )


def include_dir() -> Path:
    """ABA_PARAM.INC and VABA_PARAM.INC in upper and lower case (sources name them either way; one case only in the
    package, which must check out on case-insensitive file systems)."""
    d = cache_dir() / "include"
    d.mkdir(parents=True, exist_ok=True)
    for name in ("ABA_PARAM.INC", "VABA_PARAM.INC"):
        text = (_HERE / name).read_text()
        for variant in (name, name.lower()):
            target = d / variant
            if not target.exists() or target.read_text() != text:
                target.write_text(text)
    return d


def _compile(sources: list[Path], language: str, out: Path, flags: tuple[str, ...] = ()) -> None:
    compiler = find_compiler(language)
    cmd = [compiler, *_FLAGS[language], *flags, f"-I{include_dir()}", "-o", str(out), *map(str, sources)]
    if language == "c":
        cmd.append("-lm")
    tmp = out.with_suffix(f".tmp{os.getpid()}.so")
    cmd[cmd.index(str(out))] = str(tmp)
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        tmp.unlink(missing_ok=True)
        first = next((ln for ln in (res.stderr + res.stdout).splitlines() if "error" in ln.lower()), res.stderr.strip())
        raise PluginError(f"compiling {sources[0]} failed ({Path(compiler).name}): {first.strip()[:300]}")
    tmp.replace(out)  # atomic: a parallel worker sees the whole library or none


def build(source: Path, flags: tuple[str, ...] = ()) -> Path:
    """The compiled library of ``source`` with the extra compiler ``flags`` (compiled now unless the cache has it)."""
    language = SOURCE_SUFFIXES[source.suffix]
    compiler = find_compiler(language)
    h = hashlib.sha256()
    for part in (source.read_bytes(), compiler.encode(), " ".join([*_FLAGS[language], *flags]).encode()):
        h.update(part)
    out = cache_dir() / f"{source.stem}-{h.hexdigest()[:16]}.so"
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        _compile([source], language, out, flags)
    return out


def _utilities() -> ctypes.CDLL | None:
    """geocel's Abaqus utility routines, loaded with global symbols (None without a C compiler)."""
    key = "<utilities>"
    if key not in _LOADED:
        try:
            lib = build(_HERE / "utilities.c")
        except PluginError:
            return None
        _LOADED[key] = ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    return _LOADED[key]


def load(path: str | Path, subroutine: str, flags: tuple[str, ...] = ()) -> tuple[int, ctypes.CDLL]:
    """Load (building a source first, with the extra compiler ``flags``) the library at ``path`` and return the address of ``subroutine`` (tried as
    ``name_``, ``name``, ``NAME``; case-insensitive as Fortran) and the library. Raises :class:`PluginError`."""
    p = Path(path).expanduser()
    if not p.exists():
        raise PluginError(f"the UMAT/VUMAT library {p} does not exist")
    if p.suffix not in SOURCE_SUFFIXES and p.suffix not in LIBRARY_SUFFIXES:
        kinds = ", ".join(sorted(SOURCE_SUFFIXES) + sorted(LIBRARY_SUFFIXES))
        raise PluginError(f"{p}: unknown kind of file {p.suffix!r}; give one of {kinds}")
    _utilities()
    lib_path = build(p, tuple(flags)) if p.suffix in SOURCE_SUFFIXES else p.resolve()
    key = str(lib_path)
    if key not in _LOADED:
        try:
            _LOADED[key] = ctypes.CDLL(key)
        except OSError as err:
            raise PluginError(f"cannot load {lib_path}: {err}") from None
    lib = _LOADED[key]
    base = subroutine.lower()
    for name in (f"{base}_", base, base.upper(), subroutine):
        try:
            fn = getattr(lib, name)
        except AttributeError:
            continue
        return ctypes.cast(fn, ctypes.c_void_p).value or 0, lib
    raise PluginError(
        f"{p} has no subroutine {subroutine!r} (looked for {base}_, {base}, {base.upper()}): check "
        "[soil] subroutine"
    )


def abort_requests() -> tuple[int, str]:
    """How many times a subroutine called XIT or STDB_ABQERR(-3) since the last :func:`reset_aborts`, and the
    last message."""
    lib = _LOADED.get("<utilities>")
    if lib is None:
        return 0, ""
    lib.geocel_abort_message.restype = ctypes.c_char_p
    return int(lib.geocel_abort_count()), (lib.geocel_abort_message() or b"").decode(errors="replace").strip()


def reset_aborts() -> None:
    lib = _LOADED.get("<utilities>")
    if lib is not None:
        lib.geocel_abort_reset()
