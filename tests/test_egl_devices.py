# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.gpu.egl_devices: the machine's EGL devices, in EGL's order, each named."""
from __future__ import annotations

from hybrid_engine.gpu import egl_devices
from hybrid_engine.gpu.egl_devices import (EGL_DRM_DEVICE_FILE_EXT, EGL_RENDERER_EXT, EGL_VENDOR,
                                           enumerate_devices)


def test_this_machine_lists_its_devices_by_index_and_name():
    """Mesa's EGL offers its software device (a machine without a GPU); a GPU's driver offers
    the GPU, named by its vendor and renderer. Either way every device has an index and a label."""
    devices = enumerate_devices()
    assert devices, "EGL offers at least one device (Mesa's software one, or the GPU's)"
    assert [device.index for device in devices] == list(range(len(devices)))
    for device in devices:
        assert device.label == f"{device.index}: {device.name}"
        if device.software:
            assert "Mesa software renderer" in device.name and "no GPU" in device.name
        else:
            assert device.name and device.name != "EGL device" and "no GPU" not in device.name


def test_a_gpu_is_named_by_its_vendor_renderer_and_drm_node():
    name, drm_path, software = egl_devices.device_name(
        {EGL_VENDOR: "NVIDIA", EGL_RENDERER_EXT: "NVIDIA RTX A6000", EGL_DRM_DEVICE_FILE_EXT: "/dev/dri/card7"},
        "EGL_EXT_device_drm EGL_EXT_device_query_name")
    assert name.startswith("NVIDIA NVIDIA RTX A6000 (/dev/dri/card7")
    assert drm_path == "/dev/dri/card7" and not software


def test_a_device_that_offers_no_strings_still_gets_a_name():
    assert egl_devices.device_name({}, "")[0] == "EGL device"


def test_without_an_egl_library_the_list_is_empty():
    assert enumerate_devices("libEGL-that-does-not-exist.so.9") == []
