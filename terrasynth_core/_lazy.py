"""Lazy package exports (PEP 562): a package's public names are imported
from their modules on first use, not when the package is imported.

So ``import terrasynth_core.cli.main`` (``terrasynth-cli --help``) costs no
numpy, scipy, scikit-image or PyMaxflow, and a command imports only the
stages it uses, while ``from terrasynth_core.synthesis import Session``
keeps working.  Each package also imports its names under
``typing.TYPE_CHECKING``, so type checkers and import-linter (which reads
those imports) still see every dependency.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module


def lazy_exports(
    package: str, exports: Mapping[str, tuple[str, ...]]
) -> tuple[Callable[[str], object], Callable[[], list[str]], list[str]]:
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of a package whose
    names load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to tuple of str
        Relative module name (``".ppa"``) to the names it exports.

    Returns
    -------
    (__getattr__, __dir__, __all__)
        ``__getattr__(name)`` imports the module of ``name``, stores the
        value in the package (later look-ups skip it) and returns it; any
        other name raises AttributeError as usual.
    """
    home = {name: module for module, names in exports.items() for name in names}
    namespace = import_module(package).__dict__

    def __getattr__(name: str):
        module = home.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(home))

    return __getattr__, __dir__, sorted(home)
