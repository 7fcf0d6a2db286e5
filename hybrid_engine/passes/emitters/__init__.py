# SPDX-License-Identifier: GPL-3.0-or-later
"""Emissive triangles as lights: the emitter table and its CDF (gpu_shaders/emitters/)."""
