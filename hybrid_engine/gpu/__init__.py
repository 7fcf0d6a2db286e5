# SPDX-License-Identifier: GPL-3.0-or-later
"""The GPU plumbing every pass shares: the one GL context, the shader loader, binding by name, dispatch and storage-block limits, render targets and pass timing."""
