# SPDX-License-Identifier: GPL-3.0-or-later
"""``hybrid_rt.test_gpu``: run the GPU self-test (hybrid_engine/reports/self_test.py) and report it."""
from __future__ import annotations

import bpy

from ..blender_adapter.gl_host import gl_block
from ..hybrid_engine.reports import self_test


class HYBRID_RT_OT_test_gpu(bpy.types.Operator):
    """Compile and run every pass on a small scene and compare a trace with the CPU: whether this GPU and driver run Hybrid RT correctly"""

    bl_idname = "hybrid_rt.test_gpu"
    bl_label = "Test GPU"
    bl_options = {"REGISTER"}

    def execute(self, context):
        with gl_block():
            result = self_test.run_self_test()
        self.report({"INFO"} if result.ok else {"ERROR"}, result.summary())
        return {"FINISHED"} if result.ok else {"CANCELLED"}


def register() -> None:
    bpy.utils.register_class(HYBRID_RT_OT_test_gpu)


def unregister() -> None:
    bpy.utils.unregister_class(HYBRID_RT_OT_test_gpu)
