"""Stop with one line when another folder named ``kr210_sim`` shadows the installed package.

Run from a folder that holds a clone named ``kr210_sim`` (or any ``kr210_sim/`` folder), Python
imports that folder as ``kr210_sim``: a namespace package when it has no ``__init__.py`` (the
clone's top level), or a foreign package when it has another one. The package's ``__init__``
then never runs, so ``from kr210_sim import __version__`` fails with a traceback. The modules
under it are still reached (an editable install's finder supplies them when the shadowing folder
lacks them), and this is one of them: the console entry point (:mod:`kr210_sim.cli`) and
``python -m kr210_sim`` import it before anything else, and importing it exits (2) with a
one-line hint when the package is shadowed.

Standard library only, and nothing from the package: the package is what may be missing.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: The folder of the package this module belongs to.
PACKAGE_DIR = Path(__file__).resolve().parent


def shadowing_folder() -> Path | None:
    """The folder imported as ``kr210_sim`` when it is not this package's, else None."""
    package = sys.modules.get("kr210_sim")
    if package is None:
        return None
    init = getattr(package, "__file__", None)
    if init is not None:
        folder = Path(init).resolve().parent
        return None if folder == PACKAGE_DIR else folder
    for entry in getattr(package, "__path__", ()):  # a namespace package: its folders
        folder = Path(entry).resolve()
        if folder.is_dir() and folder != PACKAGE_DIR:
            return folder
    return None


def shadow_message(folder: Path) -> str:
    """The one-line hint for ``folder`` shadowing the package."""
    if (folder / "__init__.py").is_file():
        what, fix = "another package", "run from another folder"
    else:  # a clone's top level: its package is one level down
        what, fix = "a folder without __init__.py", f"run from another folder, or cd into {folder}"
    return (
        f"kr210_sim: error: {folder} ({what}) is imported as kr210_sim instead of the installed "
        f"package ({PACKAGE_DIR}): {fix}"
    )


def exit_when_shadowed() -> None:
    """Exit 2 with :func:`shadow_message` when another folder is imported as ``kr210_sim``."""
    folder = shadowing_folder()
    if folder is not None:
        print(shadow_message(folder), file=sys.stderr)
        raise SystemExit(2)


exit_when_shadowed()  # on import: the entry points import this module first
