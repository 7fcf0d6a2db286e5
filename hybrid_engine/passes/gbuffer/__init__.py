# SPDX-License-Identifier: GPL-3.0-or-later
"""The primary G-buffer (paper §3.1; GLSL in gpu_shaders/gbuffer/)."""
