# SPDX-License-Identifier: GPL-3.0-or-later
"""Deferred shading of the primary G-buffer and its ambient occlusion (paper §3.5; GLSL in gpu_shaders/shading/)."""
