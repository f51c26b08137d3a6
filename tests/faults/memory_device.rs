//! Fault rows: memory_device (filled in by its owner).
