# SPDX-License-Identifier: GPL-3.0-or-later
"""Diffuse light by traced paths through the near-cube BVH and the cube map (GLSL in gpu_shaders/diffuse_light/)."""
