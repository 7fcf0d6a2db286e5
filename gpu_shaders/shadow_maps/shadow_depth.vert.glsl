// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass (paper §3.5), vertex stage: world-space vertices into one shadow
// slot of the atlas (the host sets the viewport to the slot's rectangle).
uniform mat4 u_view_proj;

in vec3 in_pos;

void main() {
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
