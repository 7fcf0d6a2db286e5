# SPDX-License-Identifier: GPL-3.0-or-later
"""The machine's EGL devices, each with a name a person recognises.

A render-farm worker with several GPUs runs one Blender process per GPU; each process must
create its GL context on its own device, or all of them share the first GPU while the others
idle. EGL lists the devices (``EGL_EXT_device_enumeration``) in the order glcontext's EGL
backend indexes them (its ``device_index``), so the index found here is the one the context is
created with. The names come from what each device offers: its vendor and renderer strings
(``EGL_EXT_device_query_name``), its DRM node (``EGL_EXT_device_drm``,
``EGL_EXT_device_drm_render_node``) with the kernel driver and PCI address behind it, or
Mesa's mark of a software device (``EGL_MESA_device_software``). Only ctypes and the EGL
library are used; where either is missing the list is empty.
"""
from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass

EGL_EXTENSIONS = 0x3055
EGL_VENDOR = 0x3053
EGL_RENDERER_EXT = 0x335F
EGL_DRM_DEVICE_FILE_EXT = 0x3233
EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377
MAX_DEVICES = 64


@dataclass(frozen=True)
class EGLDevice:
    """One EGL device: its index in EGL's list (glcontext's ``device_index``) and its name."""

    index: int
    name: str
    drm_path: str | None = None
    software: bool = False

    @property
    def label(self) -> str:
        """How lists and messages show the device: ``0: NVIDIA ... (/dev/dri/card1, ...)``."""
        return f"{self.index}: {self.name}"


def _sysfs_details(drm_path: str) -> list[str]:
    """The kernel driver and PCI address behind a DRM node (what ``lspci`` and
    ``nvidia-smi`` show an administrator), or nothing where sysfs does not say."""
    try:
        rdev = os.stat(drm_path).st_rdev
    except OSError:
        return []
    device = f"/sys/dev/char/{os.major(rdev)}:{os.minor(rdev)}/device"
    details = []
    driver = os.path.join(device, "driver")
    if os.path.islink(driver):
        details.append(os.path.basename(os.readlink(driver)))
    real = os.path.realpath(device)
    if real.count(":") >= 2:  # a PCI address such as 0000:01:00.0
        details.append(f"PCI {os.path.basename(real)}")
    return details


def device_name(strings: dict[int, str | None], extensions: str) -> tuple[str, str | None, bool]:
    """The name, DRM path and software flag of one device from the strings EGL gave for it."""
    software = "EGL_MESA_device_software" in extensions.split()
    title = " ".join(s for s in (strings.get(EGL_VENDOR), strings.get(EGL_RENDERER_EXT)) if s)
    drm_path = strings.get(EGL_DRM_DEVICE_FILE_EXT) or strings.get(EGL_DRM_RENDER_NODE_FILE_EXT)
    details = []
    if drm_path:
        details.append(drm_path)
        details.extend(_sysfs_details(drm_path))
    if software:
        title = title or "Mesa software renderer"
        details.append("no GPU")
    title = title or "EGL device"
    return (f"{title} ({', '.join(details)})" if details else title), drm_path, software


def _load_egl(library: str):
    try:
        egl = ctypes.CDLL(library)
        get_proc = egl.eglGetProcAddress
    except (OSError, AttributeError):
        return None, None, None
    get_proc.restype = ctypes.c_void_p
    get_proc.argtypes = [ctypes.c_char_p]
    query_devices = get_proc(b"eglQueryDevicesEXT")
    query_string = get_proc(b"eglQueryDeviceStringEXT")
    if not query_devices:
        return egl, None, None
    devices_fn = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p),
                                  ctypes.POINTER(ctypes.c_int))(query_devices)
    string_fn = (ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)(query_string)
                 if query_string else None)
    return egl, devices_fn, string_fn


def enumerate_devices(library: str = "libEGL.so.1") -> list[EGLDevice]:
    """The EGL devices in EGL's order; empty where EGL or device enumeration is missing
    (Windows, an EGL without ``EGL_EXT_device_enumeration``)."""
    _egl, query_devices, query_string = _load_egl(library)
    if query_devices is None:
        return []
    handles = (ctypes.c_void_p * MAX_DEVICES)()
    count = ctypes.c_int(0)
    if not query_devices(MAX_DEVICES, handles, ctypes.byref(count)):
        return []
    devices = []
    for index in range(count.value):
        strings: dict[int, str | None] = {}
        extensions = ""
        if query_string is not None:
            raw = query_string(handles[index], EGL_EXTENSIONS)
            extensions = raw.decode(errors="replace") if raw else ""
            # Ask only for what the device offers: other names set EGL's error flag.
            wanted = {
                EGL_VENDOR: "EGL_EXT_device_query_name", EGL_RENDERER_EXT: "EGL_EXT_device_query_name",
                EGL_DRM_DEVICE_FILE_EXT: "EGL_EXT_device_drm",
                EGL_DRM_RENDER_NODE_FILE_EXT: "EGL_EXT_device_drm_render_node",
            }
            for name, extension in wanted.items():
                if extension in extensions.split():
                    value = query_string(handles[index], name)
                    strings[name] = value.decode(errors="replace") if value else None
        name, drm_path, software = device_name(strings, extensions)
        devices.append(EGLDevice(index=index, name=name, drm_path=drm_path, software=software))
    return devices
