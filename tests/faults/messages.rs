//! Fault rows: messages (filled in by its owner).
