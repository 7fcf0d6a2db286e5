// SPDX-License-Identifier: GPL-3.0-or-later
// Where an object lies relative to the near cube (hybrid_engine/passes/near_cube_cull/near_cube.py CLASS_*):
// written per object by near_cube_cull/cull_objects.comp.glsl, read per triangle by
// near_cube_cull/cull_triangles.comp.glsl, which tests triangles of straddling objects only.
#ifndef HYBRID_NEAR_CUBE_CLASS_GLSL
#define HYBRID_NEAR_CUBE_CLASS_GLSL
#define CLASS_OUTSIDE 0u
#define CLASS_INSIDE 1u
#define CLASS_STRADDLING 2u
#endif
