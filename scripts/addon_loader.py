# SPDX-License-Identifier: GPL-3.0-or-later
"""Import this checkout as the add-on package ``hybrid_rt``, the way Blender imports it.

Shared by the command-line scripts (demo, timing report); running a script puts this folder
on ``sys.path``, so ``from addon_loader import load_addon`` works from any of them. Importing
it also puts the repository root on ``sys.path``: the ``benchmarks`` tooling (scene library,
benchmark) is not part of the add-on and imports the core as the top-level ``hybrid_engine``.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))


def load_addon():
    """Import the repository root as ``hybrid_rt`` (once per process)."""
    if "hybrid_rt" in sys.modules:
        return sys.modules["hybrid_rt"]
    spec = importlib.util.spec_from_file_location(
        "hybrid_rt", REPO_ROOT / "__init__.py", submodule_search_locations=[str(REPO_ROOT)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["hybrid_rt"] = module
    spec.loader.exec_module(module)
    return module
