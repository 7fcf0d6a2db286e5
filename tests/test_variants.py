# SPDX-License-Identifier: GPL-3.0-or-later
"""Kernel variant selection: the renderer string decides unless an override says otherwise."""
import pytest

from hybrid_engine.gpu import variants


def test_software_renderers_get_the_cpu_shaped_kernels():
    assert variants.choose("sort", "llvmpipe (LLVM 15.0.6, 256 bits)", override="") == "cpu"
    assert variants.choose("trace", "softpipe", override="") == "cpu"


def test_hardware_renderers_get_the_gpu_shaped_kernels():
    assert variants.choose("sort", "NVIDIA H100 80GB HBM3/PCIe/SSE2", override="") == "gpu"
    assert variants.choose("scan", "AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 17.0.6)", override="") == "gpu"


def test_an_override_for_every_kernel_wins_over_the_renderer():
    assert variants.choose("sort", "llvmpipe", override="gpu") == "gpu"
    assert variants.choose("trace", "NVIDIA", override="cpu") == "cpu"


def test_a_per_kernel_override_leaves_the_others_automatic():
    spec = "sort=gpu, trace=cpu"
    assert variants.choose("sort", "llvmpipe", override=spec) == "gpu"
    assert variants.choose("trace", "NVIDIA", override=spec) == "cpu"
    assert variants.choose("scan", "llvmpipe", override=spec) == "cpu"
    assert variants.choose("scan", "NVIDIA", override=spec) == "gpu"


def test_the_environment_variable_and_set_override_are_read(monkeypatch):
    monkeypatch.setenv(variants.ENVIRONMENT_VARIABLE, "scan=gpu")
    assert variants.choose("scan", "llvmpipe") == "gpu"
    variants.set_override("scan=cpu")
    try:
        assert variants.choose("scan", "NVIDIA") == "cpu"  # set_override beats the environment
    finally:
        variants.set_override(None)
    assert variants.choose("scan", "llvmpipe") == "gpu"


@pytest.mark.parametrize("spec", ["sortt=gpu", "sort=fast", "warp"])
def test_an_unknown_kernel_or_family_is_refused_by_name(spec):
    with pytest.raises(variants.VariantError, match="unknown"):
        variants.set_override(spec)


def test_chosen_lists_every_kernel():
    assert variants.chosen("llvmpipe", override="") == {kernel: "cpu" for kernel in variants.KERNELS}
