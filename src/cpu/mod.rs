//! The CPU reference solver.
