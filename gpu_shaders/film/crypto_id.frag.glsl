// SPDX-License-Identifier: GPL-3.0-or-later
// Cryptomatte's id raster, fragment stage: the nearest triangle's world row + 1 (0 where
// nothing was drawn: the background, which has no id), as a float: an R32F target clears
// to 0 portably (an integer one's clear through glClearColor is undefined), and rows below
// 2^24 are exact in it.
flat in int v_row;

layout(location = 0) out float out_row;

void main() {
    out_row = float(v_row + 1);
}
