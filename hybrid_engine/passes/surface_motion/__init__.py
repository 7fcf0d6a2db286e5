# SPDX-License-Identifier: GPL-3.0-or-later
"""Which primary pixels show an instance that moved since the last frame, and how it moved
(pass ``surface_motion``, for the denoiser's reprojection; GLSL in gpu_shaders/surface_motion/)."""
