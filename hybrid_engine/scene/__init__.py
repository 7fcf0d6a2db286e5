# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene as plain arrays, without OpenGL: geometry and its instances, what changed since the last frame, materials, lights, camera, bounds and the render settings."""
