# SPDX-License-Identifier: GPL-3.0-or-later
"""The recursive reflection and refraction rays through the BVH and the cube map (paper §3.4; GLSL in gpu_shaders/trace/)."""
