//! The Stage world window and the playerv client viewer, rendered with wgpu through egui.
