// The grid gather's per-spring hooks (generated/grid_block.wgsl) for a
// kernel that computes what it needs of each spring where it sums it:
// nothing to load once per spring (the compilers drop the unused values).

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

alias SpringData = u32;

fn spring_load(inc: Incident, first: BlockData, second: BlockData) -> u32 {
    return 0u;
}
