# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame's lighting resources: lights, the shadow atlas, the World's light (GLSL in gpu_shaders/lighting/)."""
