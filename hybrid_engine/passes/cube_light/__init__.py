# SPDX-License-Identifier: GPL-3.0-or-later
"""The lit cube map: the cube map's faces shaded into radiance every frame, with multi-bounce feedback and a mip chain (GLSL in gpu_shaders/cube_light/)."""
