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

log = logging.getLogger(__name__)

# Open collections, innermost last: a message goes to every one (an F12 inside a timing
# report's frame reaches both).
_open: list[list[str]] = []
_logged: set[str] = set()  # messages already written to the console (once per process)


def tell(message: str) -> None:
    """A message for the artist from inside an export (each distinct text once per collection)."""
    for gathered in _open:
        if message not in gathered:
            gathered.append(message)
    if message not in _logged:
        _logged.add(message)
        log.warning("%s", message)


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
