# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.gl_context: one context per process, clear errors when GL 4.3/EGL is missing."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from conftest import REPO_ROOT


def run_isolated(code: str, **env: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (a new process gets its own GL context)."""
    import os

    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], cwd=REPO_ROOT, capture_output=True, text=True,
        env={**os.environ, **env}, timeout=120,
    )


def test_every_caller_gets_the_same_context(gl):
    from hybrid_engine import gl_context

    assert gl_context.get_context() is gl
    assert gl.version_code >= gl_context.REQUIRED_GL_VERSION


def test_limits_report_the_drivers_storage_block_and_dispatch_limits(gl):
    from hybrid_engine import gl_context

    limits = gl_context.limits()
    assert limits.max_ssbo_block_bytes >= 1 << 24  # GL 4.3 guarantees at least 16 MiB
    assert min(limits.max_compute_workgroup_count) >= 65535


def test_unknown_backend_fails_with_a_message_naming_it_and_the_fix():
    result = run_isolated(
        """
        from hybrid_engine import gl_context
        try:
            gl_context.get_context()
        except gl_context.GLUnavailableError as exc:
            print("ERROR:", exc)
        """,
        HYBRID_RT_GL_BACKEND="nonexistent-backend",
    )
    assert "ERROR:" in result.stdout, result.stderr
    assert "nonexistent-backend" in result.stdout
    assert "EGL" in result.stdout


def test_a_driver_below_opengl_4_3_is_refused_with_the_version_it_offers(monkeypatch):
    from hybrid_engine import gl_context
    import moderngl

    class OldContext:
        version_code = 330
        info = {"GL_VERSION": "3.3 (Compatibility Profile) Mesa"}
        released = False

        def release(self):
            OldContext.released = True

    monkeypatch.setattr(moderngl, "create_context", lambda **kwargs: OldContext())
    with pytest.raises(gl_context.GLUnavailableError, match=r"OpenGL 4\.3.*3\.3"):
        gl_context._create_context()
    assert OldContext.released, "the refused context must be released"


def test_driver_refusing_the_required_version_names_opengl_4_3(monkeypatch):
    from hybrid_engine import gl_context
    import moderngl

    def refuse(**kwargs):
        raise Exception("requested OpenGL version 430, got version 410")

    monkeypatch.setattr(moderngl, "create_context", refuse)
    with pytest.raises(gl_context.GLUnavailableError, match=r"needs OpenGL 4\.3"):
        gl_context._create_context()
