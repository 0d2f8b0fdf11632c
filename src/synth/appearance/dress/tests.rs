//! Tests of S5–S8 (see the checklist F23–F27).
