"""The one switch between compiled and plain Python: `njit`, and the two things compiled
code needs beside it: `structure` (a mutable record compiled code reads and writes) and
`overload` (pick a function by the type of an argument, at compile time).

The engine is written once, as plain Python on numpy arrays, floats and named tuples, and
its functions are decorated with `njit`: with numba installed (a dependency of the project)
they run compiled by it in nopython mode; without numba, or with NUMBA_DISABLE_JIT=1, the
very same functions run as Python (the same results, slower). Compiled code keeps
Python's float semantics: no fastmath, so each operation rounds as it does in Python.

Numba keeps what it compiled on disk: in `__pycache__` beside each module when that folder
is writable (a checkout, a virtual environment), else in the user-wide cache
(~/.cache/numba, or $XDG_CACHE_HOME/numba), or in $NUMBA_CACHE_DIR/reference_impl when
$NUMBA_CACHE_DIR is set (a read-only site-packages of an installed wheel falls back to the
user-wide cache by itself; set $NUMBA_CACHE_DIR to put it elsewhere, e.g. on a machine whose
home is not writable; every copy of the package, a checkout's or an installed one, then
shares that one folder). The first process on a fresh install compiles, and any other that
needs the same function meanwhile waits for it (compile_lock.py); later ones load. Numba invalidates a cached
function when its own source file changes, but not when a function it calls in another
file does; the world's step calls into every module of this package, so here a cached
function is valid for one exact text of the whole package (`_PACKAGE_STAMP`, a hash of
its .py files): any edit anywhere in reference_impl recompiles all of it once.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

from reference_impl.compile_lock import compiling, key_of

try:
    import numba
    from numba.core import caching as _caching
    from numba.extending import overload as _numba_overload
except ImportError:  # pragma: no cover - numba is a dependency; this keeps the code runnable without it
    numba = None

# compiled functions really compile (numba installed and not switched off)
JIT = numba is not None and not numba.config.DISABLE_JIT


_PACKAGE = Path(__file__).resolve().parent


def _package_stamp() -> bytes:
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.digest()


_PACKAGE_STAMP = _package_stamp()

if JIT:
    from numba.core import sigutils as _sigutils
    from numba.core import types as _types
    from numba.core.compiler_lock import global_compiler_lock as _global_compiler_lock
    from numba.core.registry import CPUDispatcher as _CPUDispatcher

    class _Dispatcher(_CPUDispatcher):
        """numba's dispatcher, except that one process at a time compiles a function for
        given argument types into its cache (compile), and that a call from compiled code
        compiles the callee for its argument types without their constant values: numba
        would compile one copy of a function per constant integer or boolean it is called
        with (18 copies of a 3x3 matrix entry indexed by constants, measured)."""

        def get_call_template(self, args, kws):
            return super().get_call_template(tuple(_types.unliteral(a) for a in args),
                                             {k: _types.unliteral(v) for k, v in kws.items()})

        def compile(self, sig):
            """numba's compile, the only one of this function for these argument types into
            this cache on the machine (compile_lock): a process that finds another compiling
            it waits, then loads what that one saved. Its time goes to compiling_seconds."""
            args, _ = _sigutils.normalize_signature(sig)
            _clock.depth += 1
            start = time.perf_counter()
            try:
                with _global_compiler_lock, compiling(self._cache.cache_path, key_of(self.py_func, args)):
                    return super().compile(sig)
            finally:
                _clock.depth -= 1
                if _clock.depth == 0:  # a callee's compile is inside its caller's
                    _clock.seconds += time.perf_counter() - start

    def _package_locator(locator):
        """numba's cache locator `locator`, its freshness the package's text, not one file's;
        in $NUMBA_CACHE_DIR, the package's folder there is named after the package, not after
        where this copy of it lives (numba names it after the path of the source's folder)."""
        attributes = {"get_source_stamp": lambda self: _PACKAGE_STAMP}
        if locator is _caching.UserProvidedCacheLocator:
            attributes["get_suitable_cache_subpath"] = classmethod(_package_subpath)
        return type(f"Package{locator.__name__}", (locator,), attributes)

    def _package_subpath(cls, py_file):
        """A copy of this package (a checkout, a virtual environment's, a wheel's) caches in
        $NUMBA_CACHE_DIR/reference_impl: copies of one text share what one of them compiled
        (the index is keyed by that text, `_PACKAGE_STAMP`), and the compile lock of that
        folder serves them all. Any other file compiled by njit is cached as numba would."""
        if Path(py_file).resolve().parent == _PACKAGE:
            return _PACKAGE.name
        return _caching.UserProvidedCacheLocator.get_suitable_cache_subpath.__func__(cls, py_file)

    class _PackageCacheImpl(_caching.CompileResultCacheImpl):
        _locator_classes = [_package_locator(c) for c in _caching.CompileResultCacheImpl._locator_classes]

    class _PackageCache(_caching.FunctionCache):
        _impl_class = _PackageCacheImpl


def njit(function=None, *, inline: bool = False):
    """`function` compiled by numba (nopython, cached on disk for this text of the
    package), or unchanged without numba. inline=True: compiled code that calls it takes
    its body in (numba's inline="always") instead of calling a separately compiled copy,
    for the one-caller phases of a step that call much below them; numba compiles each
    function for itself and again inside every function that calls it, so a deep chain
    of calls compiles its bottom many times (inlining the 17 one-caller phases of the
    narrow phase, contact rows and solvers took the cold compile of every formulation's
    step from 239 to 216 CPU-s, its shared first half from 74 to 62 s, measured side by
    side; inlining every one-caller function, small leaves too, saved less: their typing
    in the caller costs more than their own compile). Not for a function that raises into its caller's try (lemke.lemke): numba
    catches there what a called function raises, and inlined, the raise escapes (the
    retries of lemke_or_retry never ran). Usable as @njit and @njit(inline=True)."""
    if function is None:
        return lambda f: njit(f, inline=inline)
    if not JIT:
        return function
    options = {"nopython": True, "inline": "always"} if inline else {"nopython": True}
    dispatcher = _Dispatcher(py_func=function, locals={}, targetoptions=options)
    dispatcher._cache = _PackageCache(function)  # numba's cache=True, with the package's stamp
    return dispatcher


class _Clock:
    """Wall seconds this process spent in the compile of njit functions (depth: nesting)."""
    seconds = 0.0
    depth = 0


_clock = _Clock()


def compiling_seconds() -> float:
    """Wall seconds this process has spent getting njit functions ready to run: compiling
    them, loading a compiled copy from the cache, or waiting for another process compiling
    them (0 without compilation). A caller that reads it before and after some work knows
    how much of that work's time was numba's and not the code's own."""
    return _clock.seconds


def cached(function, *args) -> bool:
    """Whether compiled code of the njit `function` for this text of the package is on disk
    (its cache index lists a compiled version; with `args`, one for their types): a call
    then loads it and compiles nothing new for those argument types. True without
    compilation (nothing to compile)."""
    if not JIT:
        return True
    try:
        index = function._cache._cache_file._load_index()
        if not args:
            return bool(index)
        types = tuple(_types.unliteral(numba.typeof(a)) for a in args)
        return function._cache._index_key(types, function.targetctx.codegen()) in index
    except (AttributeError, OSError, EOFError, ValueError):
        return False


def overload(stub, *, inline: bool = False):
    """Decorator: the typing function that picks, from the numba types of the arguments,
    the implementation compiled code runs for a call of the plain Python function `stub`
    (numba.extending.overload). Without compilation `stub` itself runs. inline=True: the
    implementation's body goes into its caller (numba's inline="always"), as njit's does,
    instead of being compiled as a function of its own (a one-line choice: it costs a
    compile of its own per formulation otherwise)."""
    if not JIT:
        return lambda typing: typing
    return _numba_overload(stub, inline="always") if inline else _numba_overload(stub)


def int_dict(length: int):
    """An empty dict from tuples of `length` integers to integers, which compiled code
    fills (numba's typed Dict), or a dict without compilation."""
    if not JIT:
        return {}
    from numba import typed, types
    return typed.Dict.empty(types.UniTuple(types.int64, length), types.int64)


def structure(cls, name: str | None = None):
    """`cls`'s fields (a NamedTuple's, or the names a class annotates) as a record that
    compiled code reads and assigns, passed as one pointer whatever it holds (a numba
    StructRef; a function taking a named tuple of 27 arrays compiles 3-4 times slower);
    a plain class with those fields without compilation. Named `name` (default: cls's
    name); build it with the fields in order, `Record(*values)`, in Python or in compiled
    code. Python reads its fields through compiled functions that return them."""
    fields = list(getattr(cls, "_fields", None) or cls.__annotations__)
    name = name or cls.__name__
    if not JIT:
        def __init__(self, *values):
            for field, value in zip(fields, values, strict=True):
                setattr(self, field, value)
        return type(name, (), {"__slots__": fields, "__init__": __init__, "__doc__": cls.__doc__,
                               "__module__": cls.__module__})
    import sys

    from numba.core import types
    from numba.experimental import structref
    module = sys.modules[cls.__module__]
    # the numba type, a module attribute so that cached code can name it
    kind = type(f"{name}Type", (types.StructRef,), {"__module__": cls.__module__})
    setattr(module, kind.__name__, kind)
    structref.register(kind)
    proxy = type(name, (structref.StructRefProxy,), {"__doc__": cls.__doc__, "__module__": cls.__module__})
    structref.define_proxy(proxy, kind, fields)
    return proxy
