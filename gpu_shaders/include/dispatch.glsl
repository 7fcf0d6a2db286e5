// Flat invocation index for dispatches that the host split over x and y.
//
// A 1D dispatch may not exceed GL_MAX_COMPUTE_WORK_GROUP_COUNT (65,535 on most drivers) groups
// in x. hybrid_engine/gpu/dispatch.py splits larger dispatches into an x-by-y grid; the kernel
// rebuilds the flat index here and guards it against the real item count (the grid overshoots
// by less than one row). Needs LOCAL_SIZE (the x workgroup size) defined by the host.
#ifndef HYBRID_DISPATCH_GLSL
#define HYBRID_DISPATCH_GLSL

uint flat_workgroup_index() {
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

uint flat_invocation_index() {
    return flat_workgroup_index() * uint(LOCAL_SIZE) + gl_LocalInvocationID.x;
}

#endif
