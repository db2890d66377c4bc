"""The examples a document synthesizes from: built-in DEMs or files.

:class:`ExampleRef` (a built-in key or a file path, optionally a crop,
loaded once and memoised) lives in the core's project package
(:mod:`terrasynth_core.project.refs`), because project files and
``terrasynth-cli synth --project`` use it too; here are the app's helpers
around it.
"""

from __future__ import annotations

from terrasynth_core.examples import BUILTIN_EXAMPLES
from terrasynth_core.project import ExampleRef

__all__ = ["ExampleRef", "builtin_refs", "chosen_cell_size", "ground_cell_text"]


def chosen_cell_size(cell_size: float | None, refs) -> float | None:
    """The run's square cell size as far as the loaded DEMs tell:
    ``cell_size`` (the parameters'), else the finest of ``refs`` (examples,
    styles and stamps); None when none is known yet."""
    if cell_size is not None:
        return float(cell_size)
    # The core's rule (run_cell_size): the finer side of the finest cell.
    return min((min(c) for c in (ref.loaded_cell_size() for ref in refs) if c is not None), default=None)


def ground_cell_text(cell_size: tuple[float, float] | None, square: float | None = None) -> str:
    """A DEM's ground cell for people: ``"92.7 x 66.1 m"`` (dy x dx), plus
    ``", square at 66.1 m"`` once the run's cell size ``square`` is known."""
    if cell_size is None:
        text = "cell size unknown"
    else:
        text = "{:.3g} x {:.3g} m".format(*cell_size)
    return text if square is None else f"{text}, square at {square:.3g} m"


def builtin_refs() -> list[ExampleRef]:
    """One reference per built-in example, in library order."""
    return [ExampleRef(builtin=ex.key) for ex in BUILTIN_EXAMPLES]


