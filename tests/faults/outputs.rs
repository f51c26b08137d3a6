//! Fault rows: outputs (filled in by its owner).
