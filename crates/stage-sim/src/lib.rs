//! A Stage 4.1.1-compatible 2D multi-robot simulation built from a `worldfile` model tree.
