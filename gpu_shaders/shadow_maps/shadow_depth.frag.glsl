// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass, fragment stage: depth only, no colour target.
void main() {
}
