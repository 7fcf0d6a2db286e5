# SPDX-License-Identifier: GPL-3.0-or-later
"""One folder per pass of the frame, each with its GLSL under the same name in gpu_shaders/."""
