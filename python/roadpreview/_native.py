"""Access to the compiled extension, with a clear error where it is missing."""

from __future__ import annotations

try:
    from . import _core
except ImportError as _err:  # source tree without a build
    _core = None
    _import_error = _err


def native_available() -> bool:
    return _core is not None


def core():
    """The compiled module, or an ImportError that says how to build it."""
    if _core is None:
        raise ImportError(
            "roadpreview's C++ extension is not built (install the package with `pip install .`); "
            f"only roadpreview.reference is available here ({_import_error})"
        )
    return _core
