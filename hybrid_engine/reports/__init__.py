# SPDX-License-Identifier: GPL-3.0-or-later
"""What is written about frames: timing reports and their charts, and the GPU self-test."""
