# SPDX-License-Identifier: GPL-3.0-or-later
"""The running mean of a view's samples, kept on the GPU (pass ``accumulate``)."""
