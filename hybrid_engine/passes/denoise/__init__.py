# SPDX-License-Identifier: GPL-3.0-or-later
"""The spatio-temporal denoiser of the frame's ambient estimate (pass ``denoise``: temporal
reprojection, a variance estimate and an edge-avoiding wavelet filter; GLSL in
gpu_shaders/denoise/)."""
