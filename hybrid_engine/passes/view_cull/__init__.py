# SPDX-License-Identifier: GPL-3.0-or-later
"""Draw lists for the raster passes (G-buffer, cube-map faces, shadow maps): per-object
frustum culling and per-triangle culling of each view on the GPU (GLSL in
gpu_shaders/view_cull/)."""
