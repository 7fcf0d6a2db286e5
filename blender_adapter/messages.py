# SPDX-License-Identifier: GPL-3.0-or-later
"""What the artist should know about an export, on its way to ``report``.

The exporter finds things an artist can fix (a missing image, an unsupported node or
colour space, an object that cannot be converted) deep inside calls that know nothing of the
render engine or the operator that asked for the export. It ``tell``s them here; the caller
that can reach Blender's ``report`` (F12's ``RenderEngine.render``, the viewport's
``view_update``, the timing report operator) wraps its export in ``collecting()`` and reports
what was gathered, so the messages reach the Info editor and the status bar, not only the
console. ``logging`` keeps a copy for developers.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from ..hybrid_engine.gpu.dispatch import GPUMemoryError, SceneLimitError
from ..hybrid_engine.gpu.gl_context import GLUnavailableError
from ..hybrid_engine.frame.film import FilmError
from ..hybrid_engine.frame.near_budget import BudgetError
from ..hybrid_engine.frame.views import ViewportError
from ..hybrid_engine.passes.scene_upload.textures import TextureLimitError
from ..hybrid_engine.reports.timing_report import TimingReportError
from ..hybrid_engine.scene.arrays import SceneDataError
from ..hybrid_engine.scene.camera import CameraError
from ..hybrid_engine.scene.settings import SettingsError
from .colour import ColourSpaceError

log = logging.getLogger(__name__)

# Errors that say what the artist can change (a camera type, a setting, a scene too big for
# the GPU, a missing GL driver): their message is the whole story, and a traceback would only
# bury it. Anything else is a bug and keeps its traceback.
ARTIST_ERRORS: tuple[type[Exception], ...] = (
    CameraError, SettingsError, SceneDataError, SceneLimitError, TextureLimitError, GPUMemoryError,
    GLUnavailableError, FilmError, BudgetError, ViewportError, TimingReportError, ColourSpaceError,
)


def is_artist_error(exc: BaseException) -> bool:
    """Whether ``exc`` is a clear message for the artist (no traceback) rather than a bug."""
    return isinstance(exc, ARTIST_ERRORS)

# Open collections, innermost last: a message goes to every one (an F12 inside a timing
# report's frame reaches both).
_open: list[list[str]] = []
_logged: set[str] = set()  # messages already written to the console (once per process)


def tell(message: str) -> None:
    """A message for the artist from inside an export (each distinct text once per collection).

    When a caller collects it, that caller's ``report`` is its one console line (Blender
    prints reports in background mode), so the log keeps it at debug level; a message nobody
    collects is logged as a warning, once per process."""
    for gathered in _open:
        if message not in gathered:
            gathered.append(message)
    if message not in _logged:
        _logged.add(message)
        log.log(logging.DEBUG if _open else logging.WARNING, "%s", message)


def is_collected() -> bool:
    """Whether a caller is collecting what ``tell`` hears now (else it reaches the console)."""
    return bool(_open)


@contextmanager
def collecting() -> Iterator[list[str]]:
    """Gather what ``tell`` hears inside the block, in order, each text once."""
    gathered: list[str] = []
    _open.append(gathered)
    try:
        yield gathered
    finally:
        _open.remove(gathered)


def report_all(report: Callable[[set, str], None] | None, gathered: list[str], prefix: str = "Hybrid RT: ") -> None:
    """Hand gathered messages to a Blender ``report(levels, text)`` as warnings."""
    if report is None:
        return
    for message in gathered:
        report({"WARNING"}, f"{prefix}{message}")
