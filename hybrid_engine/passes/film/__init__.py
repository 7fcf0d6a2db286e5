# SPDX-License-Identifier: GPL-3.0-or-later
"""The film's work on the GPU: the running mean of a view's samples (pass ``accumulate``)
and a final render's Depth, Normal and Denoising Data passes (pass ``data_passes``), its
light passes and Mist (``light_passes``), Cryptomatte (``cryptomatte``) and Vector
(``vector``)."""
