# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene on the GPU: buffers, image textures, and the instance transform that makes the world-space triangles (paper §3.3; GLSL in gpu_shaders/scene_upload/)."""
