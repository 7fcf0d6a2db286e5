# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared fixtures: the one place a GL context is made, fixed seeds, the add-on loader."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
SHARED_SCENES = REPO_ROOT.parent / "shared" / "scenes"
FAILURE_DIR = REPO_ROOT / "tests" / "_failures"

for _path in (REPO_ROOT, REPO_ROOT / "tests", REPO_ROOT / "scripts"):  # core, test helpers, addon_loader
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from addon_loader import load_addon  # noqa: E402 - the one loader, shared with the scripts

os.environ.setdefault("HYBRID_RT_DEBUG", "1")  # GL error checks after every pass in tests


@pytest.fixture(scope="session")
def gl():
    """The process-wide moderngl context (created once)."""
    from hybrid_engine.gpu import gl_context

    return gl_context.get_context()


@pytest.fixture
def ctx(gl):
    """The shared context, with the GL error flag checked before and after the test."""
    assert gl.error == "GL_NO_ERROR", "a previous test left a GL error behind"
    yield gl
    assert gl.error == "GL_NO_ERROR", "this test left a GL error behind"


@pytest.fixture(scope="module")
def renderer(gl):
    """One Renderer per test module (its GPU state kept across the module's frames)."""
    from hybrid_engine.frame.renderer import Renderer

    r = Renderer(gl)
    yield r
    r.release()


@pytest.fixture
def trace_variant(request):
    """The trace kernel's shape named by the test's indirect parameter ("cpu": the megakernel,
    "gpu": the waves), put back to the machine's choice after."""
    from hybrid_engine.gpu import variants

    variants.set_override(f"trace={request.param}")
    yield request.param
    variants.set_override(None)


@pytest.fixture
def rng():
    """A fixed-seed generator: random inputs are reproducible."""
    return np.random.default_rng(20140101)


@pytest.fixture
def addon():
    """The add-on registered in a factory-fresh Blender session; unregistered afterwards."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=False)
    module = load_addon()
    module.register()
    try:
        yield module
    finally:
        module.unregister()


def save_failure_images(name: str, **images: np.ndarray) -> Path:
    """Write images of a failing comparison where a developer can look at them."""
    FAILURE_DIR.mkdir(parents=True, exist_ok=True)
    for key, img in images.items():
        np.save(FAILURE_DIR / f"{name}_{key}.npy", img)
    return FAILURE_DIR


@pytest.fixture
def fed_session(addon):
    """A viewport session fed by Blender's depsgraph handlers, as ``view_update`` is fed in a
    viewport (``depsgraph.updates`` is only filled inside them), and its sync reports."""
    import bpy

    session = addon.blender_adapter.viewport.ViewportSession()
    reports = []

    @bpy.app.handlers.persistent  # the tests load factory settings after installing it
    def on_update(_scene, depsgraph):
        reports.append(session.update(depsgraph))

    handlers = (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post)
    for handler_list in handlers:
        handler_list.append(on_update)
    try:
        yield session, reports
    finally:
        for handler_list in handlers:
            if on_update in handler_list:
                handler_list.remove(on_update)
        session.release()
