// The `parallel_bond` stage (Potyondy & Cundall 2004): its WGSL twin of
// backend/cpu/parallel_bond.rs. Not yet built into a pipeline: the GPU backend refuses plans
// with parallel bonds (backend/gpu/parallel_bond.rs).
