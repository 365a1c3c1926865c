"""Loading the package's optional compiled loops through ctypes: one place for each of them (the elastic
map's EM, ``elmap/_emkernel.c``; the envs' force processing, ``envs/_stepkernel.c``).

The package builds them when it is installed (optional extensions: with no C compiler the install goes
on without them); each has a NumPy path that gives the same numbers. A library built from another
version of its C source (its ABI number differs) is refused with a warning, never called with wrong
arguments.
"""

from __future__ import annotations

import ctypes
import importlib.util
import warnings

#: ctypes argument types, one letter each: i int64, p pointer, d double, c int
KINDS = {"i": ctypes.c_int64, "p": ctypes.c_void_p, "d": ctypes.c_double, "c": ctypes.c_int}


def load_library(
    module: str,
    abi_symbol: str,
    abi: int,
    signatures: dict[str, tuple[str, type | None]],
    fallback: str,
    dll: type[ctypes.CDLL] = ctypes.CDLL,
) -> ctypes.CDLL | None:
    """The compiled extension ``module`` loaded as ``dll`` (``ctypes.PyDLL`` keeps the GIL through a
    call) with the argument and result types of ``signatures`` (``name: (letters, restype)``), or
    ``None``: not built, not loadable, or built with an ABI number (``abi_symbol()``) other than ``abi``
    (then a warning names ``fallback``, the path used instead)."""
    try:
        spec = importlib.util.find_spec(module)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.origin:
        return None
    try:
        lib = dll(spec.origin)
        getattr(lib, abi_symbol).restype = ctypes.c_int64
        built = getattr(lib, abi_symbol)()
    except (OSError, AttributeError):
        return None
    if built != abi:
        source = module.rsplit(".", 1)[-1] + ".c"
        warnings.warn(
            f"{spec.origin} was built from another version of {source} (ABI {built}, need {abi}); using "
            f"{fallback}. Reinstall the package (pip install -e .) to rebuild it.",
            stacklevel=3,
        )
        return None
    for name, (letters, restype) in signatures.items():
        function = getattr(lib, name)
        function.argtypes = [KINDS[k] for k in letters]
        function.restype = restype
    return lib
