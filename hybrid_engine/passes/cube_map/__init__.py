# SPDX-License-Identifier: GPL-3.0-or-later
"""The G-buffer cube map around the camera and its hit-interval pyramid (paper §3.2; GLSL in gpu_shaders/cube_map/)."""
