//! Readers for Stage 4.1.1 worldfiles (`.world`, `.inc`) and Player 3.0.2 configuration files
//! (`.cfg`), producing a resolved model tree with Stage's defaults and units applied.
