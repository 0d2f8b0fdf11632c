//! Appearance synthesis onto a mesh (S5–S8, [references: frasson §4.1.3, §4.2.3]).
