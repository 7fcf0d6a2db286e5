# SPDX-License-Identifier: GPL-3.0-or-later
"""The per-frame LBVH over the near cube's triangles (paper §3.3; GLSL in gpu_shaders/lbvh/)."""
