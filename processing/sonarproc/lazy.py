"""Public names of a package loaded from their submodules on first use (PEP 562).

A package whose ``__init__`` imports every submodule makes importing any one of them
(``sonarproc.surfaces.fitting.models``, say) load them all, scipy's solvers with them:
tenths of a second of a fresh process's start, in runs that use none of them. Such a
package lists where each public name lives and hands :func:`lazy_names` to the module's
``__getattr__``; ``from package import name`` is unchanged for its callers.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str, where: Mapping[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package`` that imports ``name`` from ``where[name]``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    where : mapping of str to str
        Each public name's defining module (absolute name).

    Returns
    -------
    callable
        ``__getattr__(name)``: the value, kept in the package's namespace so that the
        next look-up does not call it again; :class:`AttributeError` for any other name.
    """

    def __getattr__(name: str) -> Any:
        try:
            module = where[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(module), name)
        setattr(importlib.import_module(package), name, value)
        return value

    return __getattr__
