//! Fault rows: divergence (filled in by its owner).
